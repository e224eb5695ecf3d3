#!/usr/bin/env bash
# The fuzz targets' smoke run, for CI: builds them with nightly and cargo-fuzz
# (each installed if missing), then runs each target on its corpus in the
# repository (the seeds and the reproducers of past findings: libFuzzer runs
# every file of it first) and fuzzes it for FUZZ_SECONDS (default 30)
# seconds. Fails on any crash (an assertion of a harness, a panic, a
# timeout of 10 s, more than 512 MB). New inputs go to a scratch directory:
# the corpora in the repository are only read. A crash leaves its input in
# fuzz/artifacts/<target>/; see README.md for what to do with it.
# Run from anywhere: `bash fuzz/smoke.sh`.
set -euo pipefail
cd "$(dirname "$0")"

seconds=${FUZZ_SECONDS:-30}

if ! rustup run nightly rustc --version >/dev/null 2>&1; then
    rustup toolchain install nightly --profile minimal
fi
# libFuzzer itself is C++, built by libfuzzer-sys.
if ! command -v c++ >/dev/null; then
    if [[ $(id -u) -eq 0 ]]; then sudo=(); else sudo=(sudo); fi
    "${sudo[@]}" apt-get update -qq
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends g++
fi
if ! command -v cargo-fuzz >/dev/null; then
    cargo install cargo-fuzz --locked
fi

# No sanitizer: the project's code is safe Rust (`unsafe_code` denied); the
# harnesses' own assertions and libFuzzer's limits do the checking.
FUZZ_FLAGS=(--sanitizer none)
cargo +nightly fuzz build "${FUZZ_FLAGS[@]}"

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
for target in $(cargo +nightly fuzz list); do
    case $target in
        # A whole calibration file (up to 5120 bytes) and its mode byte; a
        # stream that loads one through the link.
        calibration_decode) max_len=5200 ;;
        device) max_len=8192 ;;
        # One datagram, a little more than the 4 KiB read.
        rsi_rob | egm_robot) max_len=4200 ;;
        *) max_len=4096 ;;
    esac
    mkdir -p "$scratch/$target"
    echo "==== fuzz $target for ${seconds}s ===="
    cargo +nightly fuzz run "${FUZZ_FLAGS[@]}" "$target" "$scratch/$target" "corpus/$target" -- \
        -max_total_time="$seconds" -rss_limit_mb=512 -timeout=10 -max_len="$max_len" \
        -print_final_stats=1
done
