#!/usr/bin/python3
# Open3D anchor for `lidarfuse calibrate` on the real rigs: how an established
# off-the-shelf pipeline does on the same pairs, with no initial guess, printed beside ours.
#
#   /usr/bin/python3 bench/open3d_anchor.py --seeds 10
#
# Bench only, never in CI: it needs Debian's python3-open3d (0.16) and numpy under
# /usr/bin/python3 (the shebang; a pyenv `python3` on PATH usually has no open3d), and it
# takes minutes. PyYAML is used to read our extrinsics.yaml when present, else a small
# parser written for that file.
#
# Data: --data DIR (default $LIDARFUSE_DATA_DIR/real, else ../shared/data/real beside the
# checkout), one folder per rig (SOURCES.md there says where each comes from). Each sensor's
# cloud is NAME.pcd in its own frame; references are T_A_B.txt, 4x4 row-major, metres,
# p_A = T_A_B * p_B. Points at exactly (0, 0, 0) (an Ouster organised cloud's "no return")
# and non-finite ones are dropped before anything else.
#
# Pairs (source -> target; the estimate is T_target_source):
#   edgar      frontleft -> frontright   reference T_frontright_frontleft.txt
#   opencalib  left -> top               reference T_top_left.txt
#              right -> top              reference T_top_right.txt
#              right -> left             reference inv(T_top_left) * T_top_right (no file)
# The right -> left reference composes two references' errors and SOURCES.md gives no ICP
# check of it: look at its rotation error beside the other pairs' before calling a miss.
#
# Ours: `lidarfuse calibrate --cloud NAME=FILE ... --root ROOT --out OUT.yaml` run once per
# rig with all its sensors, as a user would (--lidarfuse PATH, default build/tools/lidarfuse
# of this checkout). Exit 0 (all registered) and 2 (some refused) are results; a pair's
# estimate is inv(T_root_target) * T_root_source from the written T_root_sensor poses, so a
# sensor reached through another one (pose graph) counts, and a refused sensor is a failure.
# Our own per-pair status from the yaml is shown in the table for information.
#
# Open3D, per pair and per voxel v in --voxels (default 0.25 0.5 1 m):
#   voxel_down_sample(v); estimate_normals(KDTreeSearchParamHybrid(2v, 30));
#   compute_fpfh_feature(KDTreeSearchParamHybrid(5v, 100)); features computed once per
#   voxel and shared by all runs (their time is added to every run's wall time).
#   ransac: registration_ransac_based_on_feature_matching(mutual_filter=False,
#     max_correspondence_distance=1.5v, TransformationEstimationPointToPoint(False),
#     ransac_n=3, checkers CorrespondenceCheckerBasedOnEdgeLength(0.9) and
#     CorrespondenceCheckerBasedOnDistance(1.5v), RANSACConvergenceCriteria(100000, 0.999)),
#     once per seed 0..N-1 (--seeds, default 10), o3d.utility.random.seed(seed) before each.
#     Open3D's RANSAC runs OpenMP threads drawing from one shared generator, so a seed is
#     reproducible only with --threads 1 (OMP_NUM_THREADS, set before open3d is imported).
#   fgr: registration_fgr_based_on_feature_matching with
#     FastGlobalRegistrationOption(maximum_correspondence_distance=1.5v); it takes no seed,
#     so it runs once per voxel (after o3d.utility.random.seed(0)).
#   Each global result is refined by Open3D's G-ICP (registration_generalized_icp,
#   TransformationEstimationForGeneralizedICP, ICPConvergenceCriteria(max_iteration=50)),
#   coarse to fine: first on the v clouds with max correspondence distance 2v, then on
#   clouds downsampled at --fine-voxel f (default 0.25 m) with max distance 2f. The second
#   stage gives every voxel the same final accuracy, so the voxel decides only whether the
#   global stage lands in G-ICP's basin, which is what the comparison is about.
#   (No open3d.geometry.KDTreeFlann: its numpy-array searches crashed once on this machine.)
#
# Success: within 0.3 deg and 10 cm of the reference. The references are not ground truth
# (SOURCES.md: an independent ICP started at them moves 0.5-7 cm and 0.01-0.06 deg), so a
# tighter bound would grade the reference, not the registration; a wrong basin is metres or
# degrees off, far outside. Ours is graded with the same bound. Errors: translation
# |t_est - t_ref| (m), rotation angle of R_ref^T R_est (deg).
#
# Output: `name value unit` lines on stdout, per pair
#   anchor_<rig>_<source>_<target>_ours_{success,translation_error,rotation_error}
#   anchor_<rig>_ours_wall_time                          (one run per rig)
#   anchor_<rig>_<source>_<target>_open3d_<ransac|fgr>_v<voxel>_
#       {success_rate, median_translation_error, median_rotation_error, median_wall_time}
# (medians over all runs, failed ones included; ours' errors only when it registered), and
# a readable table on stderr. Exit 1 when ours could not be run (Open3D figures are still
# printed), else 0.
import argparse
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CHECKOUT = os.path.dirname(HERE)

# rig folder -> short name, root, sensors (clouds NAME.pcd), pairs (source, target)
RIGS = {
    "edgar_ouster_pair": {
        "short": "edgar",
        "root": "frontright",
        "sensors": ["frontright", "frontleft"],
        "pairs": [("frontleft", "frontright")],
    },
    "opencalib_road_rig": {
        "short": "opencalib",
        "root": "top",
        "sensors": ["top", "left", "right"],
        "pairs": [("left", "top"), ("right", "top"), ("right", "left")],
    },
}

SUCCESS_DEG = 0.3
SUCCESS_M = 0.10


def parse_args():
    env = os.environ.get("LIDARFUSE_DATA_DIR")
    default_data = (os.path.join(env, "real") if env
                    else os.path.join(CHECKOUT, "..", "shared", "data", "real"))
    p = argparse.ArgumentParser(
        description="Open3D FPFH+RANSAC / FGR (+G-ICP) vs lidarfuse calibrate on the real rigs")
    p.add_argument("--data", default=default_data,
                   help="folder holding the rig folders (default %(default)s)")
    p.add_argument("--lidarfuse", default=os.path.join(CHECKOUT, "build", "tools", "lidarfuse"),
                   help="lidarfuse binary (default %(default)s)")
    p.add_argument("--seeds", type=int, default=10, help="RANSAC seeds per voxel (default 10)")
    p.add_argument("--voxels", type=float, nargs="+", default=[0.25, 0.5, 1.0],
                   help="voxel sizes in metres (default 0.25 0.5 1)")
    p.add_argument("--fine-voxel", type=float, default=0.25,
                   help="voxel of the second G-ICP stage (default 0.25 m)")
    p.add_argument("--rig", action="append", choices=sorted(RIGS),
                   help="rig folder to run (repeatable; default all)")
    p.add_argument("--threads", type=int, default=0,
                   help="OMP_NUM_THREADS for Open3D (default: leave as is)")
    p.add_argument("--verbose", action="store_true",
                   help="also print every Open3D run's errors on stderr")
    return p.parse_args()


ARGS = parse_args()
if ARGS.threads > 0:
    os.environ["OMP_NUM_THREADS"] = str(ARGS.threads)

import numpy as np  # noqa: E402
try:
    import open3d as o3d  # noqa: E402
except ImportError:
    sys.exit("no open3d: run with Debian's /usr/bin/python3 (apt install python3-open3d)")
try:
    import yaml  # noqa: E402
except ImportError:
    yaml = None

REG = o3d.pipelines.registration


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def emit(name, value, unit):
    if isinstance(value, float):
        value = f"{value:.6g}"
    print(f"{name} {value} {unit}", flush=True)


# ---------------------------------------------------------------- geometry

def load_T(path):
    T = np.loadtxt(path, dtype=float)
    if T.shape != (4, 4):
        raise ValueError(f"{path}: not a 4x4 matrix")
    return T


def inv_T(T):
    R, t = T[:3, :3], T[:3, 3]
    out = np.eye(4)
    out[:3, :3] = R.T
    out[:3, 3] = -R.T @ t
    return out


def reference(rig_dir, root, source, target):
    """T_target_source from the rig's files: direct if present, else through the root."""
    direct = os.path.join(rig_dir, f"T_{target}_{source}.txt")
    if os.path.exists(direct):
        return load_T(direct)

    def T_root(name):
        return np.eye(4) if name == root else load_T(os.path.join(rig_dir, f"T_{root}_{name}.txt"))
    return inv_T(T_root(target)) @ T_root(source)


def errors(T_est, T_ref):
    dt = float(np.linalg.norm(T_est[:3, 3] - T_ref[:3, 3]))
    c = (np.trace(T_ref[:3, :3].T @ T_est[:3, :3]) - 1.0) / 2.0
    dr = math.degrees(math.acos(max(-1.0, min(1.0, c))))
    return dt, dr


def is_success(dt, dr):
    return dt <= SUCCESS_M and dr <= SUCCESS_DEG


def quat_wxyz_to_R(q):
    w, x, y, z = (float(v) for v in q)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


# ---------------------------------------------------------------- ours

def parse_extrinsics_fallback(text):
    """Just enough of extrinsics.yaml: sensors (name, registered, translation, rotation_wxyz,
    reason) and pairs (source, target, status), for when PyYAML is missing."""
    out = {"sensors": [], "pairs": []}
    section, cur = None, None
    for raw in text.splitlines():
        line = raw.rstrip()
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        if not line.startswith(" "):
            section = line.split(":", 1)[0].strip()
            cur = None
            continue
        s = line.strip()
        if s.startswith("- "):
            cur = {}
            if section in out:
                out[section].append(cur)
            s = s[2:]
        m = re.match(r"([A-Za-z_]+):\s*(.*)$", s)
        if not m or cur is None:
            continue
        key, val = m.group(1), m.group(2).strip()
        if val.startswith("["):
            cur[key] = [float(v) for v in val.strip("[]").split(",")]
        elif val in ("true", "false"):
            cur[key] = val == "true"
        elif val:
            cur[key] = val.strip("'\"")
        if key in ("translation", "rotation_wxyz"):
            cur.setdefault("T_root_sensor", {})[key] = cur[key]
    return out


def run_ours(binary, rig_dir, spec, clouds, tmpdir):
    """Returns (T_root_sensor dict for registered sensors, pair status dict, wall s) or None."""
    out_yaml = os.path.join(tmpdir, f"{spec['short']}_extrinsics.yaml")
    cmd = [binary, "calibrate"]
    for name in spec["sensors"]:
        cmd += ["--cloud", f"{name}={clouds[name]}"]
    cmd += ["--root", spec["root"], "--out", out_yaml]
    t0 = time.monotonic()
    try:
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              universal_newlines=True)
    except OSError as e:
        log(f"ours: cannot run {binary}: {e}")
        return None
    wall = time.monotonic() - t0
    if proc.returncode not in (0, 2) or not os.path.exists(out_yaml):
        log(f"ours: {' '.join(cmd)} exited {proc.returncode}:\n{proc.stdout}")
        return None
    with open(out_yaml) as f:
        text = f.read()
    doc = yaml.safe_load(text) if yaml else parse_extrinsics_fallback(text)
    poses, reasons = {}, {}
    for s in doc.get("sensors") or []:
        name = str(s.get("name"))
        if s.get("registered") and s.get("T_root_sensor"):
            T = np.eye(4)
            T[:3, :3] = quat_wxyz_to_R(s["T_root_sensor"]["rotation_wxyz"])
            T[:3, 3] = [float(v) for v in s["T_root_sensor"]["translation"]]
            poses[name] = T
        else:
            reasons[name] = str(s.get("reason", "not registered"))
    pair_status = {}
    for p in doc.get("pairs") or []:
        pair_status[(str(p.get("source")), str(p.get("target")))] = str(p.get("status"))
    return poses, reasons, pair_status, wall


# ---------------------------------------------------------------- Open3D

def read_cloud(path):
    pc = o3d.io.read_point_cloud(path)
    pts = np.asarray(pc.points, dtype=np.float64)
    keep = np.all(np.isfinite(pts), axis=1) & np.any(pts != 0.0, axis=1)
    out = o3d.geometry.PointCloud()
    out.points = o3d.utility.Vector3dVector(pts[keep])
    return out, int(len(pts) - keep.sum())


def features(pc, voxel, with_fpfh=True):
    down = pc.voxel_down_sample(voxel)
    down.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
    if not with_fpfh:
        return down, None
    fpfh = REG.compute_fpfh_feature(
        down, o3d.geometry.KDTreeSearchParamHybrid(radius=5 * voxel, max_nn=100))
    return down, fpfh


def gicp(src, tgt, max_dist, init):
    return REG.registration_generalized_icp(
        src, tgt, max_dist, init, REG.TransformationEstimationForGeneralizedICP(),
        REG.ICPConvergenceCriteria(max_iteration=50)).transformation


def refine(T, coarse, fine, voxel, fine_voxel):
    T = gicp(coarse[0], coarse[1], 2 * voxel, T)
    return gicp(fine[0], fine[1], 2 * fine_voxel, T)


def ransac(src, tgt, fs, ft, voxel):
    d = 1.5 * voxel
    return REG.registration_ransac_based_on_feature_matching(
        src, tgt, fs, ft, False, d, REG.TransformationEstimationPointToPoint(False), 3,
        [REG.CorrespondenceCheckerBasedOnEdgeLength(0.9),
         REG.CorrespondenceCheckerBasedOnDistance(d)],
        REG.RANSACConvergenceCriteria(100000, 0.999)).transformation


def fgr(src, tgt, fs, ft, voxel):
    return REG.registration_fgr_based_on_feature_matching(
        src, tgt, fs, ft,
        REG.FastGlobalRegistrationOption(maximum_correspondence_distance=1.5 * voxel)
    ).transformation


def voxel_tag(v):
    return f"v{v:g}"


# ---------------------------------------------------------------- main

def main():
    rigs = ARGS.rig or list(RIGS)
    seeds = list(range(max(1, ARGS.seeds)))
    voxels = ARGS.voxels
    ours_failed = False
    table = []  # (pair label, rows[(config, succ, runs, med_dt, med_dr, med_wall, note)])
    tmpdir = tempfile.mkdtemp(prefix="open3d_anchor.")
    log(f"open3d {o3d.__version__}, data {os.path.abspath(ARGS.data)}, seeds {len(seeds)}, "
        f"voxels {' '.join(f'{v:g}' for v in voxels)}, fine G-ICP voxel {ARGS.fine_voxel:g}, "
        f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")
    try:
        for rig in rigs:
            spec = RIGS[rig]
            rig_dir = os.path.join(ARGS.data, rig)
            clouds = {n: os.path.join(rig_dir, f"{n}.pcd") for n in spec["sensors"]}

            ours = run_ours(ARGS.lidarfuse, rig_dir, spec, clouds, tmpdir)
            if ours is None:
                ours_failed = True
            else:
                emit(f"anchor_{spec['short']}_ours_wall_time", ours[3], "s")

            pcs = {}
            for n, path in clouds.items():
                pcs[n], dropped = read_cloud(path)
                log(f"{spec['short']} {n}: {len(pcs[n].points)} points "
                    f"({dropped} zero or non-finite dropped)")
            feats = {}  # (name, voxel) -> (down, fpfh, seconds)
            for n in spec["sensors"]:
                for v in sorted(set(voxels) | {ARGS.fine_voxel}):
                    t0 = time.monotonic()
                    down, fpfh = features(pcs[n], v, with_fpfh=v in voxels)
                    feats[(n, v)] = (down, fpfh, time.monotonic() - t0)

            for source, target in spec["pairs"]:
                prefix = f"anchor_{spec['short']}_{source}_{target}"
                T_ref = reference(rig_dir, spec["root"], source, target)
                rows = []
                if ours is not None:
                    poses, reasons, pair_status, wall = ours
                    status = pair_status.get((source, target), "no direct pair")
                    if source in poses and target in poses:
                        T = inv_T(poses[target]) @ poses[source]
                        dt, dr = errors(T, T_ref)
                        ok = is_success(dt, dr)
                        emit(f"{prefix}_ours_success", int(ok), "bool")
                        emit(f"{prefix}_ours_translation_error", dt, "m")
                        emit(f"{prefix}_ours_rotation_error", dr, "deg")
                        rows.append(("ours", int(ok), 1, dt, dr, wall,
                                     f"pair status: {status}"))
                    else:
                        emit(f"{prefix}_ours_success", 0, "bool")
                        why = "; ".join(f"{k}: {reasons.get(k, '')}" for k in (source, target)
                                        if k not in poses)
                        rows.append(("ours", 0, 1, None, None, wall, f"refused ({why})"))
                else:
                    rows.append(("ours", 0, 0, None, None, None, "could not run"))

                fine = (feats[(source, ARGS.fine_voxel)][0], feats[(target, ARGS.fine_voxel)][0])
                for method in ("ransac", "fgr"):
                    for v in voxels:
                        src, fs, ts = feats[(source, v)]
                        tgt, ft, tt = feats[(target, v)]
                        feat_s = ts + tt
                        runs = []
                        for seed in (seeds if method == "ransac" else [0]):
                            o3d.utility.random.seed(seed)
                            t0 = time.monotonic()
                            if method == "ransac":
                                T0 = ransac(src, tgt, fs, ft, v)
                            else:
                                T0 = fgr(src, tgt, fs, ft, v)
                            T = refine(T0, (src, tgt), fine, v, ARGS.fine_voxel)
                            wall = feat_s + time.monotonic() - t0
                            dt, dr = errors(T, T_ref)
                            runs.append((is_success(dt, dr), dt, dr, wall))
                            if ARGS.verbose:
                                log(f"{prefix} {method} {voxel_tag(v)} seed {seed}: "
                                    f"{dt:.3f} m {dr:.3f} deg {wall:.2f} s")
                        n_ok = sum(r[0] for r in runs)
                        med_dt = statistics.median(r[1] for r in runs)
                        med_dr = statistics.median(r[2] for r in runs)
                        med_w = statistics.median(r[3] for r in runs)
                        cfg = f"open3d_{method}_{voxel_tag(v)}"
                        emit(f"{prefix}_{cfg}_success_rate", 100.0 * n_ok / len(runs), "%")
                        emit(f"{prefix}_{cfg}_median_translation_error", med_dt, "m")
                        emit(f"{prefix}_{cfg}_median_rotation_error", med_dr, "deg")
                        emit(f"{prefix}_{cfg}_median_wall_time", med_w, "s")
                        rows.append((f"{method} {voxel_tag(v)}", n_ok, len(runs), med_dt, med_dr,
                                     med_w, ""))
                table.append((f"{spec['short']} {source} -> {target}", rows))
    finally:
        for f in os.listdir(tmpdir):
            os.remove(os.path.join(tmpdir, f))
        os.rmdir(tmpdir)

    log("")
    log(f"success: within {SUCCESS_DEG:g} deg and {SUCCESS_M * 100:g} cm of the reference; "
        "errors are medians over the runs; "
        "open3d wall time: both clouds' features at that voxel + global + G-ICP; "
        "ours: one process per rig (reading clouds included), its time is the rig's")
    for label, rows in table:
        log("")
        log(label)
        log(f"  {'method':<12} {'success':>9} {'t_err_m':>9} {'r_err_deg':>10} {'wall_s':>8}  note")
        for cfg, ok, n, dt, dr, w, note in rows:
            fmt = (lambda x, d: f"{x:.{d}f}" if x is not None else "-")
            log(f"  {cfg:<12} {f'{ok}/{n}':>9} {fmt(dt, 3):>9} {fmt(dr, 3):>10} "
                f"{fmt(w, 2):>8}  {note}")
    return 1 if ours_failed else 0


if __name__ == "__main__":
    sys.exit(main())
