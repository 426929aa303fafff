#!/usr/bin/env bash
# context_checks.sh API_CPP: fails when an entry point of the C API (an LSNIF_API function in
# API_CPP) takes an `LsnifContext context` and its body does not check the handle first with
# check_context(context) or live(context) (src/lsnif/plugin/api.cpp: a handle that is not a live
# context, a destroyed one included, is refused unread). A new entry point is covered without a
# test of its own; the device-free test PluginApi.AContextThatIsNotLiveIsRefusedUnread runs the check.
set -euo pipefail
api=$1
[ -f "$api" ] || { echo "context_checks.sh: $api not found" >&2; exit 1; }
awk '
  /^LSNIF_API / { in_fn = 1; sig = ""; body = ""; name = $0; sub(/\(.*/, "", name); n = split(name, w, " "); name = w[n] }
  in_fn && !open { sig = sig $0 }
  in_fn && /\{/ { open = 1 }
  in_fn && open { body = body $0 "\n" }
  in_fn && open && /^}/ {
    if (sig ~ /LsnifContext context/) {
      ++checked
      if (body !~ /check_context\(context\)/ && body !~ /live\(context\)/) { print "context_checks.sh: " name " takes a context and does not check it (check_context)"; ++bad }
    }
    in_fn = 0; open = 0
  }
  END {
    if (checked < 15) { print "context_checks.sh: found only " checked " entry points taking a context"; exit 1 }
    if (bad) exit 1
    print "context_checks.sh: " checked " entry points taking a context, each checks it"
  }' "$api"
