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
# Whether this build has CGAL. ctest sets PLIANT_WITH_CGAL (1 or 0) from the build's option, and
# that decides which branch a script takes; the mesher is asked too, and a disagreement (a CGAL
# build whose mesher fails) is a failure, never a silent skip of the CGAL checks. Run by hand
# without the variable, the mesher's answer decides.
has_cgal() {
  local probe=0
  "$pliant" mesh --implicit sphere --cell-size 0.05 -o "$work/cgal_probe.vtu" >"$work/cgal_probe.out" 2>&1 && probe=1
  if [ -z "${PLIANT_WITH_CGAL:-}" ]; then [ "$probe" = 1 ]; return; fi
  if [ "$PLIANT_WITH_CGAL" != "$probe" ]; then
    fail "cgal_probe: the build has PLIANT_WITH_CGAL=$PLIANT_WITH_CGAL but meshing a sphere gave $probe"
    sed 's/^/    /' "$work/cgal_probe.out" | tail -5
  fi
  [ "$PLIANT_WITH_CGAL" = 1 ]
}
