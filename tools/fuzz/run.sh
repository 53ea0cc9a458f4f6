#!/usr/bin/env bash
# Runs fuzz targets one after another and prints executions, crashes, ooms and timeouts for each.
#
#   tools/fuzz/run.sh [-t SECONDS] [-n RUNS] [-j JOBS] [TARGET...]
#
#   -t SECONDS  time per target (default 60 when -n is not given)
#   -n RUNS     executions per target (e.g. -n 10000000 for the full campaign); with -t as well,
#               a target stops at whichever comes first
#   -j JOBS     parallel libFuzzer jobs per target (default 1)
#   TARGET      default: every target in Cargo.toml
#
# Each target runs in libFuzzer's fork mode with crashes, ooms and timeouts counted rather than
# fatal (-ignore_crashes/-ignore_ooms/-ignore_timeouts), under -rss_limit_mb=512 (the readers'
# ceiling inside the targets is 256 MiB) and -timeout=10. Inputs reach 128 KiB, except where a
# larger input only repeats what a smaller one reaches and costs its time in every execution:
# 16 KiB for the text readers (their records are line-local: 16 KiB holds hundreds), 8 KiB for
# read_gz (it gzips its input before reading: the framing and the ceiling, not the content, are
# what it is for; the per-format targets take the content) and 4 KiB for values (a thousand
# values exercise every model of the range coder). Findings land in artifacts/<target>/;
# each becomes a regression file in crates/io/tests/fixtures/regress/. Corpora come from
# ./seed.sh (run first if corpus/ is empty). Needs cargo-fuzz (`cargo install cargo-fuzz`); on a
# stable toolchain the targets build with --sanitizer none. Exit status: 1 if anything was found.
set -euo pipefail
cd "$(dirname "$0")"
secs="" runs="" jobs=1
while getopts "t:n:j:" o; do
    case $o in
        t) secs=$OPTARG ;;
        n) runs=$OPTARG ;;
        j) jobs=$OPTARG ;;
        *) sed -n '2,22p' "$0"; exit 2 ;;
    esac
done
shift $((OPTIND - 1))
[ -n "$secs$runs" ] || secs=60
targets=("$@")
fuzz() { cargo fuzz "$1" --fuzz-dir . "${@:2}"; }
# `stress` is a plain binary (no libFuzzer entry point), not a target.
[ ${#targets[@]} -gt 0 ] || mapfile -t targets < <(fuzz list | grep -vx stress)
[ -d corpus ] || ./seed.sh >/dev/null
mkdir -p logs
printf '%-10s %12s %8s %6s %9s %8s\n' target executions crashes ooms timeouts seconds
found=0
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t" "artifacts/$t"
    stop=()
    [ -z "$runs" ] || stop+=(-runs="$runs")
    [ -z "$secs" ] || stop+=(-max_total_time="$secs")
    case $t in
        read_obj | read_ply | read_off | read_xyz | read_conf) max_len=16384 ;;
        read_gz) max_len=8192 ;;
        values) max_len=4096 ;;
        *) max_len=131072 ;;
    esac
    fuzz build --sanitizer none "$t" >"logs/$t.build.log" 2>&1 || { echo "$t: does not build (logs/$t.build.log)"; found=1; continue; }
    start=$(date +%s)
    fuzz run --sanitizer none "$t" "corpus/$t" -- \
        -fork="$jobs" -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1 \
        -rss_limit_mb=512 -malloc_limit_mb=512 -timeout=10 -max_len=$max_len \
        -artifact_prefix="artifacts/$t/" "${stop[@]}" >"logs/$t.log" 2>&1 || true
    took=$(($(date +%s) - start))
    # Fork mode reports "#EXECS: cov: .. oom/timeout/crash: O/T/C ..." as it goes; take the last.
    last=$(grep -a 'oom/timeout/crash:' "logs/$t.log" | tail -1 || true)
    execs=$(sed -n 's/^#\([0-9]*\):.*/\1/p' <<<"$last")
    otc=$(sed -n 's/.*oom\/timeout\/crash: \([0-9]*\/[0-9]*\/[0-9]*\).*/\1/p' <<<"$last")
    IFS=/ read -r oom tmo crash <<<"${otc:-0/0/0}"
    printf '%-10s %12s %8s %6s %9s %8s\n' "$t" "${execs:-?}" "$crash" "$oom" "$tmo" "$took"
    [ "$crash$oom$tmo" = "000" ] || found=1
    [ -n "$execs" ] || { echo "  (no statistics: see tools/fuzz/logs/$t.log)"; found=1; }
done
exit $found
