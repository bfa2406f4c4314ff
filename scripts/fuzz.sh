#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, clang-14, ASan + UBSan) and runs each for a bounded time, two at a
# time (PENUMBRA_FUZZ_JOBS):
#   scripts/fuzz.sh [seconds-per-target] [target...]     (default 60 s; targets: raw nrrd nifti dicom tiff vti vtk vdb zarr pdb mmcif gro xyz xtc dcd scene)
# Each target starts from its committed seeds (fuzz/seeds/<target>) plus the corpus earlier runs grew
# (build/fuzz-out/corpus/<target>), with its dictionary (fuzz/dict/<target>.dict). A crash, a leak, a
# sanitizer report, a timeout (> 10 s for one input) or an out-of-memory (> 2 GB) fails the run: the
# input is kept as build/fuzz-out/crashes/<target>/crash-* (or leak-, timeout-, oom-) and the script
# exits 1 after running the other targets. Reproduce with build/fuzz/fuzz/fuzz_<target> <file>.
# The figures of each run (executions, cov, ft) go to build/fuzz-out/summary.txt.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(raw nrrd nifti dicom tiff vti vtk vdb zarr pdb mmcif gro xyz xtc dcd scene)
build="${PENUMBRA_FUZZ_BUILD:-build/fuzz}"
out="${PENUMBRA_FUZZ_OUT:-build/fuzz-out}"

./scripts/install-deps.sh
launcher=()
command -v ccache > /dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
# -O1 with line tables: quick to build, fast enough to fuzz, symbolised reports.
CC=clang-14 CXX=clang++-14 cmake -S . -B "$build" -G Ninja -DPENUMBRA_FUZZ=ON -DCMAKE_BUILD_TYPE=None \
  -DCMAKE_CXX_FLAGS="-O1 -gline-tables-only" -DCMAKE_C_FLAGS="-O1 -gline-tables-only" \
  -DPENUMBRA_BUILD_TESTS=OFF -DPENUMBRA_BUILD_BENCH=OFF -DCMAKE_UNITY_BUILD=ON "${launcher[@]}" > /dev/null
cmake --build "$build" -j "${PENUMBRA_FUZZ_JOBS:-2}" --target "${targets[@]/#/fuzz_}"

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
mkdir -p "$out"
summary="$out/summary.txt"
export PENUMBRA_FUZZ_TMP
PENUMBRA_FUZZ_TMP="$(mktemp -d "$( [ -d /dev/shm ] && echo /dev/shm || echo "${TMPDIR:-/tmp}")/penumbra-fuzz.XXXXXX")"
trap 'rm -rf "$PENUMBRA_FUZZ_TMP"' EXIT
echo "# $(date -u +%FT%TZ) $(git describe --always --dirty 2>/dev/null || echo unknown), ${seconds} s per target" >> "$summary"
# One target: its run, its summary line (and on failure the report) on stdout, exit 1 when it failed.
fuzz_one() {
  local t="$1"
  local corpus="$out/corpus/$t" crashes="$out/crashes/$t" log="$out/$t.log"
  mkdir -p "$corpus" "$crashes"
  local status=0
  local dict=()
  [ -f "fuzz/dict/$t.dict" ] && dict=(-dict="fuzz/dict/$t.dict")
  local max_len=16384
  [ "$t" = vdb ] && max_len=131072  # OpenVDB writes a grid's internal nodes whole: the smallest files are ~40 KB
  # Its own temporary folder: targets running at once must not share input files.
  PENUMBRA_FUZZ_TMP="$PENUMBRA_FUZZ_TMP/$t" "$build/fuzz/fuzz_$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len="$max_len" \
    "${dict[@]}" -artifact_prefix="$crashes/" -print_final_stats=1 \
    "$corpus" "fuzz/seeds/$t" > "$log" 2>&1 || status=$?
  local runs last cov ft line
  runs=$(grep -o 'stat::number_of_executed_units: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*$' || true)
  last=$(grep -E '^#[0-9]+' "$log" | tail -1 || true)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<< "$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<< "$last")
  line=$(printf '%-6s %10s execs  cov %6s  ft %6s  corpus %5s files' "$t" "${runs:-?}" "${cov:-?}" "${ft:-?}" \
         "$(find "$corpus" -type f | wc -l)")
  if [ "$status" -ne 0 ]; then
    echo "$line  FAILED (exit $status): $(ls "$crashes" | tail -1)"
    grep -m1 -E 'ERROR: |runtime error|==[0-9]+==' "$log" || true
    tail -40 "$log"
    return 1
  fi
  echo "$line"
}

# Each fuzzer is one process on one core: as many run at once as there are jobs (PENUMBRA_FUZZ_JOBS,
# default 2), each for its full time. Their reports are printed in the targets' order.
jobs="${PENUMBRA_FUZZ_JOBS:-2}"
reports="$PENUMBRA_FUZZ_TMP/reports"
mkdir -p "$reports"
echo "== ${#targets[@]} targets, ${seconds} s each, $jobs at a time"
pids=()
for t in "${targets[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done
  ( fuzz_one "$t" > "$reports/$t.txt" 2>&1; echo $? > "$reports/$t.rc" ) &
  pids+=($!)
done
wait "${pids[@]}" || true
failed=()
for t in "${targets[@]}"; do
  echo "== fuzz_$t"
  cat "$reports/$t.txt"
  head -1 "$reports/$t.txt" >> "$summary"
  [ "$(cat "$reports/$t.rc" 2>/dev/null || echo 1)" = 0 ] || failed+=("$t")
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzzing found problems in: ${failed[*]} (inputs under $out/crashes, logs $out/<target>.log)"
  exit 1
fi
