#!/usr/bin/env bash
# expect.sh RC REGEX CMD...: runs CMD, passes if it exits with RC and its output matches REGEX.
set -u
want_rc=$1 regex=$2
shift 2
out=$("$@" 2>&1)
rc=$?
printf '%s\n' "$out"
if [ "$rc" -ne "$want_rc" ]; then echo "expect.sh: exit code $rc, expected $want_rc"; exit 1; fi
if ! printf '%s\n' "$out" | grep -Eq -- "$regex"; then echo "expect.sh: output does not match /$regex/"; exit 1; fi
exit 0
