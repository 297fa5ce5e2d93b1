#!/usr/bin/env bash
# `make fuzz`: runs every fuzz target (libFuzzer, built by the sanitizer build) for SECONDS from
# its committed corpus, new inputs going to a scratch corpus in OUT, never into the repository.
# A crash, leak, sanitizer report or timeout stops that target; its input is kept in
# OUT/<target>/ and the script fails naming it (copy it into tests/fuzz/corpus/<target>/ once
# fixed: it is a regression test from then on). OUT/summary.tsv: target, executions, seconds,
# corpus size, result.
# Usage: tests/fuzz/run-fuzzers.sh TEST_BIN_DIR SECONDS OUT
set -uo pipefail
bin=$1 seconds=$2 out=$3
here=$(cd "$(dirname "$0")" && pwd)
targets=(wire recording checkpoint config hdr_image gltf jpeg_frame)
rm -rf "$out"
mkdir -p "$out"
printf 'target\texecutions\tseconds\tcorpus\tresult\n' > "$out/summary.tsv"
failed=()
for t in "${targets[@]}"; do
  exe="$bin/fuzz_$t"
  [ -x "$exe" ] || { echo "fuzz: $exe is missing (build the fuzz_targets target)"; exit 2; }
  mkdir -p "$out/$t/corpus"
  # The big inputs (a glTF model, a JPEG frame, an EXR) need room; the rest stay small so the
  # fuzzer spends its time on structure, not size.
  case $t in gltf|jpeg_frame|hdr_image) max_len=65536 ;; *) max_len=16384 ;; esac
  start=$(date +%s)
  "$exe" "$out/$t/corpus" "$here/corpus/$t" -max_total_time="$seconds" -max_len=$max_len \
    -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$out/$t/" \
    > "$out/$t/log.txt" 2>&1
  status=$?
  elapsed=$(( $(date +%s) - start ))
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$out/$t/log.txt" | tail -1)
  corpus=$(find "$out/$t/corpus" "$here/corpus/$t" -type f | wc -l)
  if [ $status -eq 0 ]; then
    result=ok
  else
    artifact=$(ls "$out/$t"/crash-* "$out/$t"/leak-* "$out/$t"/timeout-* "$out/$t"/oom-* 2>/dev/null | head -1)
    result="FAILED (${artifact:-see $out/$t/log.txt})"
    failed+=("$t")
  fi
  printf '%s\t%s\t%s\t%s\t%s\n' "$t" "${execs:-?}" "$elapsed" "$corpus" "$result" >> "$out/summary.tsv"
  printf 'fuzz %-11s %9s executions in %3s s, corpus %5s: %s\n' "$t" "${execs:-?}" "$elapsed" \
    "$corpus" "$result"
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: findings in ${failed[*]}; the logs and inputs are in $out/"
  exit 1
fi
echo "fuzz: no findings; $out/summary.tsv"
