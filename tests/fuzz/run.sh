#!/bin/sh
# run.sh: builds every libFuzzer harness of tests/fuzz/ with clang (-fsanitize=fuzzer,address,
# undefined) against a sanitized libhdnet.a, makes the seed corpora (make_seeds.py) and runs each
# target for FUZZ_SECONDS seconds. Prints one line per target (executions, coverage, corpus size)
# and exits 1 on any finding (a crash, a sanitizer report, a leak, a timeout or an allocation over
# the limit): the input that caused it is kept in BUILD/findings/ to become a file of
# tests/data/broken/. Called by `make fuzz` (which first builds BUILD/libhdnet.a with clang).
# Usage: sh tests/fuzz/run.sh BUILD HDNET SECONDS [TARGET...]
set -u
build=$1 hdnet=$2 seconds=$3
shift 3
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
targets=${*:-png jpeg pfm light safetensors model obj warp tfjs serve lights_csv}
python=/usr/bin/python3
[ -x "$python" ] || python=python3
mkdir -p "$build/fuzz" "$build/findings"
libs=$(cd "$root" && make -s print-ldlibs BUILD="$build")
cflags="-O1 -g -fno-omit-frame-pointer -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all -std=c11 \
-D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE -Wall -Wextra -fopenmp -I$root/include -I$root/src"
failed=0
"$python" "$here/make_seeds.py" "$hdnet" "$build/seeds" || exit 1
export OMP_NUM_THREADS=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
# the harnesses write each input to a file: on a tmpfs that is six times faster than on a disk
[ -z "${TMPDIR:-}" ] && [ -d /dev/shm ] && [ -w /dev/shm ] && export TMPDIR=/dev/shm
printf '%-12s %10s %8s %8s %7s  %s\n' target executions exec/s coverage corpus result
for t in $targets; do
    case $t in
    png | jpeg | pfm) src=fuzz_image.c defs="-DFUZZ_FORMAT=\"$t\"" ;;
    model) src=fuzz_safetensors.c defs=-DFUZZ_MODEL ;;
    *) src=fuzz_$t.c defs= ;;
    esac
    extra= # the serve harness links the files of tools/ it tests
    [ "$t" = serve ] && extra="$root/tools/serve/image_memory.c $root/tools/serve/lights.c $root/tools/light_words.c"
    bin=$build/fuzz/fuzz_$t
    # shellcheck disable=SC2086
    clang $cflags $defs -o "$bin" "$here/$src" $extra "$build/libhdnet.a" $libs || { failed=1; continue; }
    corpus=$build/corpus/$t
    mkdir -p "$corpus"
    log=$build/fuzz/$t.log
    "$bin" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
        -artifact_prefix="$build/findings/$t-" "$corpus" "$build/seeds/$t" >"$log" 2>&1
    rc=$?
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    speed=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | sed 's/cov: //')
    units=$(find "$corpus" -type f | wc -l)
    result=ok
    if [ "$rc" -ne 0 ]; then
        result="FINDING (exit $rc): $(ls "$build/findings/$t-"* 2>/dev/null | head -1)"
        failed=1
        grep -E 'ERROR|SUMMARY|runtime error|==[0-9]+==' "$log" | head -8 >&2
    fi
    printf '%-12s %10s %8s %8s %7s  %s\n' "$t" "${runs:-?}" "${speed:-?}" "${cov:-?}" "$units" "$result"
done
exit $failed
