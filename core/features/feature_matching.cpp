#include "core/features/feature_matching.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <nanoflann.hpp>

namespace lidarfuse::core {

namespace {

// nanoflann dataset adaptor over a vector of 33-D descriptors.
struct DescriptorAdaptor {
    const std::vector<FpfhDescriptor>* descriptors;
    std::size_t kdtree_get_point_count() const { return descriptors->size(); }
    float kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*descriptors)[i][dim]; }
    template <class BoundingBox>
    bool kdtree_get_bbox(BoundingBox&) const {
        return false;
    }
};

using DescriptorTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Adaptor<float, DescriptorAdaptor, float>,
                                        DescriptorAdaptor, kFpfhSize, std::uint32_t>;

class DescriptorIndex {
public:
    explicit DescriptorIndex(const std::vector<FpfhDescriptor>& descriptors)
        : adaptor_{&descriptors},
          tree_(kFpfhSize, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {
        tree_.buildIndex();
    }
    // Up to k nearest (index, squared distance), nearest first.
    std::size_t knn(const FpfhDescriptor& query, std::size_t k, std::uint32_t* indices,
                    float* squared_distances) const {
        if (adaptor_.descriptors->empty() || k == 0) return 0;
        nanoflann::KNNResultSet<float, std::uint32_t> result(k);
        result.init(indices, squared_distances);
        tree_.findNeighbors(result, query.data(), nanoflann::SearchParams());
        return result.size();
    }

private:
    DescriptorAdaptor adaptor_;
    DescriptorTree tree_;
};

}  // namespace

Correspondences match_features(const std::vector<FpfhDescriptor>& source,
                               const std::vector<FpfhDescriptor>& target,
                               const FeatureMatchingParams& params) {
    Correspondences matches;
    if (source.empty() || target.empty()) return matches;
    const DescriptorIndex target_index(target);
    std::unique_ptr<DescriptorIndex> source_index;
    if (params.mutual) source_index = std::make_unique<DescriptorIndex>(source);

    const std::size_t candidates =
        params.mutual ? 1 : static_cast<std::size_t>(std::max(1, params.candidates_per_source));
    const std::size_t k = std::min(target.size(), std::max<std::size_t>(candidates, 2));
    std::vector<std::uint32_t> indices(k);
    std::vector<float> d2(k);
    const double max_d2 = params.max_descriptor_distance > 0.0
                              ? params.max_descriptor_distance * params.max_descriptor_distance
                              : std::numeric_limits<double>::infinity();
    for (std::size_t s = 0; s < source.size(); ++s) {
        const std::size_t found = target_index.knn(source[s], k, indices.data(), d2.data());
        if (found == 0) continue;
        // Ratio test on distances (nanoflann returns squared ones).
        if (params.ratio < 1.0 && found >= 2 &&
            std::sqrt(static_cast<double>(d2[0])) >
                params.ratio * std::sqrt(static_cast<double>(d2[1]))) {
            continue;
        }
        for (std::size_t c = 0; c < std::min(found, candidates); ++c) {
            if (static_cast<double>(d2[c]) > max_d2) break;
            if (params.mutual) {
                std::uint32_t back = 0;
                float back_d2 = 0.0f;
                source_index->knn(target[indices[c]], 1, &back, &back_d2);
                // Equal distances: accept when the back match ties with this source.
                if (back != s && back_d2 < d2[c]) continue;
            }
            matches.push_back({static_cast<std::uint32_t>(s), indices[c], std::sqrt(d2[c])});
        }
    }
    return matches;
}

}  // namespace lidarfuse::core
