#!/bin/sh
# CTest driver of one fuzz target: runs the fuzzer for a bounded time on a scratch copy of its seed corpus (the
# checked-in corpus is never modified) and fails on any crash, sanitizer report, timeout or over-limit allocation.
#   run_fuzzer.sh FUZZER SEED_DIR DICT SECONDS ARTIFACT_DIR
#   run_fuzzer.sh --skip REASON      (exit 77: CTest reports the test as skipped)
if [ "$1" = "--skip" ]; then
  echo "fuzz test skipped: $2"
  exit 77
fi
fuzzer=$1 seeds=$2 dict=$3 seconds=$4 artifacts=$5
if [ ! -x "$fuzzer" ]; then
  echo "fuzz test skipped: $fuzzer was not built"
  exit 77
fi
scratch=$(mktemp -d "${TMPDIR:-/tmp}/cpmesh-fuzz-run.XXXXXX") || exit 1
trap 'rm -rf "$scratch"' EXIT INT TERM
mkdir -p "$scratch/corpus" "$scratch/tmp" "$artifacts" || exit 1
cp "$seeds"/* "$scratch/corpus/" || exit 1
dict_arg=
[ -f "$dict" ] && dict_arg="-dict=$dict"
# Detached data file names in headers resolve next to the input, inside the scratch directory (fuzz_common.h).
# -malloc_limit_mb: one allocation above it is a bug (a size taken from a header without the parser's own checks);
# -rss_limit_mb bounds the whole process. -timeout: one input running longer than that is a hang.
cd "$scratch" || exit 1
TMPDIR="$scratch/tmp" \
ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=0:detect_leaks=1}" \
UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}" \
  "$fuzzer" -max_total_time="$seconds" -timeout=5 -rss_limit_mb=2048 -malloc_limit_mb=1024 \
    -print_final_stats=1 -artifact_prefix="$artifacts/" $dict_arg "$scratch/corpus"
rc=$?
if [ $rc -ne 0 ]; then
  echo "FUZZ FAILURE (exit $rc). Reproducers kept in $artifacts:"
  for f in "$artifacts"/*; do
    [ -f "$f" ] || continue
    echo "== $f ($(wc -c <"$f") bytes); rerun: $fuzzer $f"
    od -A x -t x1z -v "$f" | head -n 40
  done
fi
exit $rc
