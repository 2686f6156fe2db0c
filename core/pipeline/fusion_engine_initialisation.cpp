// FusionEngine: initial registrations handed out as jobs (or run inline) and applied when
// they finish (see fusion_engine_impl.hpp).
#include <algorithm>
#include <exception>

#include "core/pipeline/fusion_engine_impl.hpp"

namespace lidarfuse::core {

namespace {

// The follow-up that starts the tracks of the sensors `p`'s job registers (all of them but
// the root when `root_tracked`) into p->starts, on the job's thread. Shared pointers and
// copies only: it touches nothing of the engine.
void start_tracks_after(PendingInitialisation* p, bool root_tracked, int threads) {
    p->job->set_follow_up([starts = p->starts, frame = p->frame, root_tracked,
                           threads](const InitialRegistrationResult& result) {
        std::vector<std::size_t> registered;  // positions in the order
        for (std::size_t k = root_tracked ? 1 : 0; k < result.sensors.size(); ++k) {
            if (k < starts->scans.size() && result.sensors[k].registered) registered.push_back(k);
        }
        starts->tracks.resize(starts->scans.size());
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
        for (std::size_t r = 0; r < registered.size(); ++r) {
            const std::size_t k = registered[r];
            try {
                TrackScratch scratch;
                starts->tracks[k] = starts->start(frame, k, result, &scratch);
            } catch (const std::exception&) {
                // Out of memory: left to the engine (no exception may leave an OpenMP team).
            }
        }
    });
}

}  // namespace

void FusionEngine::Impl::request_initialisation(std::int64_t frame, const FrameInput& in,
                                                const std::vector<std::size_t>& sensors, bool first,
                                                const Eigen::Isometry3d& T_root0_root_now,
                                                std::vector<std::size_t>* started,
                                                FrameOutput* out) {
    const std::size_t root = params.root_sensor;
    PendingInitialisation p;
    p.frame = frame;
    p.first = first;
    p.starts = std::make_shared<TrackStarts>();
    p.starts->params = shared_params;
    p.starts->T_root0_root = T_root0_root_now;
    p.order.push_back(root);
    for (std::size_t s : sensors) {
        if (s != root) p.order.push_back(s);
    }
    const bool run_inline = params.initial_registration_inline;
    if (!run_inline && first) {
        tracks[root]->start(frame, in.sensors[root], Eigen::Isometry3d::Identity(),
                            thread_scratch());
        graph.add_node(node_id(root, frame), Eigen::Isometry3d::Identity(), true);
        started->push_back(root);
        started_first[root] = true;
        out->health[root].event = "initialised";
        if (p.order.size() == 1) return;  // a station of one: nothing to register
    }
    std::vector<PointCloud> clouds;
    for (std::size_t s : p.order) {
        p.starts->scans.push_back(in.sensors[s]);
        PointCloud c;
        cast_points(in.sensors[s].points, &c.points);
        clouds.push_back(std::move(c));
    }
    const int threads =
        run_inline || !tracking_beyond_root() ? params.num_threads : params.initial_threads;
    p.job = std::make_shared<InitialRegistrationJob>(std::move(clouds), params.initial, threads);
    start_tracks_after(&p, tracks[root]->initialised(), threads);
    pending = std::move(p);
    if (run_inline) {
        pending->job->run();
        apply_initialisation(frame, started, out);
    } else {
        out->initial_job = pending->job;
        for (std::size_t k = 1; k < pending->order.size(); ++k) {
            out->health[pending->order[k]].event = "initial registration started";
        }
    }
}

bool FusionEngine::Impl::tracking_beyond_root() const {
    for (std::size_t s = 0; s < n; ++s) {
        if (s != params.root_sensor && tracks[s]->initialised()) return true;
    }
    return false;
}

void FusionEngine::Impl::apply_initialisation(std::int64_t frame, std::vector<std::size_t>* started,
                                              FrameOutput* out) {
    const PendingInitialisation p = std::move(*pending);
    pending.reset();
    const auto& result = p.job->result();
    out->applied_registration =
        FrameOutput::AppliedRegistration{p.job, p.order, p.starts->T_root0_root, p.first};
    bool any_failed = false;
    std::vector<std::size_t> registered;  // positions in p.order
    for (std::size_t k = 0; k < p.order.size(); ++k) {
        const std::size_t s = p.order[k];
        const bool is_root = s == params.root_sensor;
        if (is_root && tracks[s]->initialised()) continue;  // only a reference here
        if (k >= result.sensors.size() || !result.sensors[k].registered) {
            out->health[s].event_is_problem = true;
            out->health[s].event = std::string("initial registration failed: ") +
                                   (k < result.sensors.size() ? to_string(result.sensors[k].status)
                                                              : p.job->error().c_str());
            any_failed = true;
            continue;
        }
        registered.push_back(k);
    }
    // The tracks the job's follow-up started are taken over. Any it did not start (it threw)
    // start here as new tracks too, in parallel as in prepare_tracks.
    TrackStarts& starts = *p.starts;
    const int threads = std::max(1, params.num_threads);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (std::size_t r = 0; r < registered.size(); ++r) {
        const std::size_t k = registered[r];
        std::unique_ptr<SensorTrack>& track = tracks[p.order[k]];
        if (k < starts.tracks.size() && starts.tracks[k]) {
            track = std::move(starts.tracks[k]);
            continue;
        }
        track = starts.start(p.frame, k, result, thread_scratch());
    }
    for (const std::size_t k : registered) {
        const std::size_t s = p.order[k];
        const bool is_root = s == params.root_sensor;
        graph.add_node(node_id(s, p.frame), tracks[s]->reference_pose(), is_root);
        started->push_back(s);
        started_first[s] = p.first;
        reanchored_frame[s] = -1;
        out->health[s].event = p.first || is_root ? "initialised" : "reinitialised";
        suspicious[s] = 0;
        needs_reinit[s] = false;
    }
    if (p.first || any_failed) last_retry_frame = frame;
}

}  // namespace lidarfuse::core
