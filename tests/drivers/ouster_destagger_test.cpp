// Destagger / restagger: definition on a small image, exact round trips for the shifts of
// real sensors and random ones.

#include <gtest/gtest.h>

#include <numeric>
#include <random>

#include "drivers/ouster/destagger.hpp"
#include "drivers/ouster/metadata.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::ouster {
namespace {

TEST(OusterDestagger, MovesEachRowByItsShift) {
    const int h = 3;
    const int w = 5;
    std::vector<int> img(h * w);
    std::iota(img.begin(), img.end(), 0);
    const std::vector<int> shift{0, 2, -1};
    std::vector<int> out(img.size());
    destagger(img.data(), h, w, shift, out.data());
    EXPECT_EQ(out, (std::vector<int>{0, 1, 2, 3, 4,          // unchanged
                                     8, 9, 5, 6, 7,          // out[(m + 2) % 5] = in[m]
                                     11, 12, 13, 14, 10}));  // out[(m - 1) % 5] = in[m]
    std::vector<int> back(img.size());
    restagger(out.data(), h, w, shift, back.data());
    EXPECT_EQ(back, img);
    EXPECT_EQ(destaggered_column(0, 2, w, shift), 4);
    EXPECT_EQ(destaggered_column(4, 1, w, shift), 1);
}

TEST(OusterDestagger, RoundTripsRealAndRandomShifts) {
    std::vector<std::vector<int>> shifts;
    std::vector<int> widths;
    for (const char* name :
         {"crc_test.json", "same_ports_nonlegacy.2.json", "OS-0-128-U1_v2.3.0_1024x10.json",
          "OS-1-64_sensor_config_reduced.json"}) {
        if (const auto path = test::ouster_file(name)) {
            const SensorInfo info = load_metadata(*path);
            shifts.push_back(info.pixel_shift_by_row);
            widths.push_back(info.columns_per_frame);
        }
    }
    std::mt19937 rng(11);
    for (int k = 0; k < 20; ++k) {
        const int w = 16 + static_cast<int>(rng() % 300);
        std::vector<int> s(1 + rng() % 40);
        for (auto& v : s) v = static_cast<int>(rng() % (2 * w - 1)) - (w - 1);  // |s| < w
        shifts.push_back(s);
        widths.push_back(w);
    }
    for (std::size_t k = 0; k < shifts.size(); ++k) {
        const int h = static_cast<int>(shifts[k].size());
        const int w = widths[k];
        std::vector<std::uint16_t> img(static_cast<std::size_t>(h) * w);
        for (auto& v : img) v = static_cast<std::uint16_t>(rng());
        std::vector<std::uint16_t> d(img.size()), back(img.size());
        destagger(img.data(), h, w, shifts[k], d.data());
        restagger(d.data(), h, w, shifts[k], back.data());
        ASSERT_EQ(back, img) << "case " << k;
        // Every pixel lands where destaggered_column says.
        for (int row = 0; row < h; row += 7) {
            for (int m = 0; m < w; m += 13) {
                ASSERT_EQ(
                    d[static_cast<std::size_t>(row) * w + destaggered_column(m, row, w, shifts[k])],
                    img[static_cast<std::size_t>(row) * w + m]);
            }
        }
    }
}

}  // namespace
}  // namespace lidarfuse::ouster
