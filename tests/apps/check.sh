# Shared by the command-line tests (sourced): `check NAME EXPECTED_STATUS PATTERN -- command...`
# runs the command, and passes when its exit status is EXPECTED_STATUS and its output (stdout and
# stderr) matches the extended regular expression PATTERN; a failure prints the first 30 lines of
# the output and counts in `failures`, which the script reports at its end.
failures=0

check() {
  local name=$1 expected=$2 pattern=$3
  shift 4
  local output status
  output=$("$@" 2>&1)
  status=$?
  if [ "$status" -ne "$expected" ]; then
    echo "FAIL $name: exit status $status, expected $expected; output:"; echo "$output" | head -30
    failures=$((failures + 1))
  elif ! grep -qE -- "$pattern" <<<"$output"; then
    echo "FAIL $name: output does not match /$pattern/:"; echo "$output" | head -30
    failures=$((failures + 1))
  else
    echo "ok   $name"
  fi
}
