// lidarfused: the station daemon. Until the daemon issue lands, it validates its command
// line and says plainly that fusion is not available; it never pretends to fuse.
#include <cstdio>
#include <cstring>

int main(int argc, char** argv) {
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--help") || !std::strcmp(argv[i], "-h")) {
            std::printf("usage: lidarfused --config STATION.yaml\n");
            return 0;
        }
    }
    std::fprintf(stderr,
                 "lidarfused: the fusion pipeline is not built yet (see the daemon issue); "
                 "use `lidarfuse inspect` / `lidarfuse replay` for ingest.\n");
    return 3;
}
