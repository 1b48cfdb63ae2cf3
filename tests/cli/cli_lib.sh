# Shared by the command-line test scripts (sourced, after they set $work): the check that runs a
# command and matches its exit code and output, pass/fail counters, and a PNG's size.
passed=0; failed=0
check() {  # check NAME EXPECTED_EXIT GREP_PATTERN(stderr+stdout, or "") -- command...
  local name=$1 want=$2 pattern=$3; shift 4
  "$@" >"$work/$name.out" 2>&1; local got=$?
  if [ "$got" -ne "$want" ]; then
    echo "FAIL $name: exit $got, expected $want"; sed 's/^/    /' "$work/$name.out" | tail -5; failed=$((failed+1)); return
  fi
  if [ -n "$pattern" ] && ! grep -qE -- "$pattern" "$work/$name.out"; then
    echo "FAIL $name: output lacks /$pattern/"; sed 's/^/    /' "$work/$name.out" | tail -5; failed=$((failed+1)); return
  fi
  echo "ok   $name"; passed=$((passed+1))
}
ok() { echo "ok   $1"; passed=$((passed+1)); }
fail() { echo "FAIL $1"; failed=$((failed+1)); }
# Width x height from a PNG's IHDR chunk; "" if the file is not a PNG.
png_size() {
  [ "$(head -c 8 "$1" 2>/dev/null | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ] || return 0
  od -An -tu1 -j16 -N8 "$1" 2>/dev/null | awk '{printf "%dx%d", $1*16777216+$2*65536+$3*256+$4, $5*16777216+$6*65536+$7*256+$8}'
}
scene() { printf '%s\n' "$2" > "$work/$1.json"; }  # scene NAME JSON: writes $work/NAME.json
