#!/usr/bin/env bash
# Soak: lidarfused's Pipeline under a looped simulated station for a long time, sampling
# RSS, latency (last packet of a frame -> outputs written), fusion time and counters.
#   bench/soak_run.sh BUILD_DIR [MINUTES=30] [SENSORS=4] [SAMPLE_S=30]
# Prints load_bench's `load_t ...` series (one line per sample) and its final figures, then
# the RSS and latency drift between the first and last quarter of the run: flat means
# rss_drift_mib near 0 and latency_drift_ms small next to the latency itself.
set -euo pipefail
build="$1"; minutes="${2:-30}"; sensors="${3:-4}"; sample="${4:-30}"
log="$(mktemp)"
nice -n 5 "$build/bench/load_bench" --sensors "$sensors" --seconds "$((minutes * 60))" \
    --sample-s "$sample" --series | tee "$log"
# n starts at 0 explicitly: an unset n would index the first sample as rss[""], and the
# first quarter's mean would count a 0 in its place (it read 11 MiB low for a 30-sample run).
awk 'BEGIN { n = 0 }
     /^load_t / { t[n] = $2; rss[n] = $5; lat[n] = $7; n++ }
     END {
         if (n < 4) { print "soak_samples " n " samples (too few for drift)"; exit }
         q = int(n / 4)
         for (i = 0; i < q; i++) { r0 += rss[i]; l0 += lat[i]; r1 += rss[n - 1 - i]; l1 += lat[n - 1 - i] }
         printf "soak_samples %d samples\n", n
         printf "soak_rss_first_quarter %.1f MiB\nsoak_rss_last_quarter %.1f MiB\n", r0 / q, r1 / q
         printf "soak_rss_drift %.1f MiB\n", (r1 - r0) / q
         printf "soak_latency_first_quarter %.1f ms\nsoak_latency_last_quarter %.1f ms\n", l0 / q, l1 / q
         printf "soak_latency_drift %.1f ms\n", (l1 - l0) / q
     }' "$log"
rm -f "$log"
