# Sourced by the shell tests: `run COMMAND...` leaves the exit code, stderr and stdout of a run in
# "$code", "$err" and "$out" (through files in "$work", which the sourcing script creates).
run() {
  set +e
  "$@" > "$work/out" 2> "$work/err"
  code=$?
  set -e
  out=$(cat "$work/out")
  err=$(cat "$work/err")
}
