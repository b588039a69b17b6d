#!/usr/bin/env bash
# Forwards the demo's GUI port to this network namespace: every DDS participant stays in the demo's private
# network namespace; only this one TCP port is forwarded, from 127.0.0.1:PORT here to 127.0.0.1:PORT in there
# (socat, one connection each, entering the namespace with nsenter). Waits for the demo to write its env file
# (newer than this script's start), then serves until SIGTERM (or until socat fails: the port is in use).
#   gui_forward.sh PORT ENV_FILE LOG_FILE
set -uo pipefail
port="$1" env_file="$2" log_file="$3"
[[ "$port" =~ ^[0-9]+$ ]] || exit 0  # demo.sh refuses it with the reason
started=$(date +%s)
pid=""
for _ in $(seq 1 1200); do
  if [ -f "$env_file" ] && [ "$(stat -c %Y "$env_file")" -ge "$started" ]; then
    pid=$(sed -n 's/^CAIRN_DEMO_PID=//p' "$env_file")
    break
  fi
  sleep 0.1
done
if [ -z "$pid" ]; then echo "gui: the demo did not start: no port forwarded" >&2; exit 1; fi
socat "TCP-LISTEN:$port,bind=127.0.0.1,reuseaddr,fork" \
  "EXEC:nsenter --net=/proc/$pid/ns/net -- socat STDIO TCP\:127.0.0.1\:$port" 2>"$log_file" &
socat_pid=$!
trap 'kill -TERM $socat_pid 2>/dev/null; exit 0' TERM INT
if ! wait "$socat_pid"; then
  echo "gui: cannot forward 127.0.0.1:$port (in use? try --gui-port): $(tail -1 "$log_file")" >&2
  exit 1
fi
