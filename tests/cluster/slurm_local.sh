#!/usr/bin/env bash
# slurm_local.sh start DIR | stop DIR
#
# Runs a throw-away single-node Slurm cluster (Debian 12's slurm-wlm 22.05 and
# munge) on localhost, so a test can submit a real job array. Everything lives
# under DIR: munge key, socket, pid/log/seed files, slurm.conf, state, spool.
# No system path (/etc/munge, /run/munge, /etc/slurm, /var/...) is touched.
#
#   start  makes DIR (absent, empty, or left by an earlier start/stop), starts
#          munged, slurmctld and slurmd as the current user, waits (<= 60 s)
#          until sinfo shows the node idle, and prints `export SLURM_CONF=...`.
#          On failure it names the step, shows the daemon log's tail, stops
#          what it started and exits 1. Exits 77 (skip) when the daemons or
#          the client commands are not installed.
#   stop   cancels the cluster's jobs, stops slurmd, slurmctld and munged via
#          DIR's pid files (a pid counts only if its command line names DIR),
#          waits for them to exit, and ends leftover job steps (slurmstepd
#          holding DIR/log/slurmd.log open) with their processes. Repeatable.
#
# `sbatch --wait` exits with the highest exit code of the array's tasks (1 if
# a task was killed by a signal or cancelled), so a failing task fails it.
set -euo pipefail

readonly WAIT_IDLE_S=60 WAIT_EXIT_S=20

die() { echo "slurm_local: $*" >&2; exit 1; }

usage() { echo "usage: $0 start|stop DIR" >&2; exit 2; }

# pid_for DIR FILE: prints the pid in FILE when that process is alive and its
# command line names DIR (so a reused pid is never signalled).
pid_for() {
  local dir=$1 file=$2 pid arg
  [[ -s $file ]] || return 1
  pid=$(tr -dc '0-9' <"$file")
  [[ -n $pid ]] || return 1
  while IFS= read -r -d '' arg; do
    if [[ $arg == "$dir/"* || $arg == *"=$dir/"* ]]; then
      echo "$pid"
      return 0
    fi
  done 2>/dev/null <"/proc/$pid/cmdline"
  return 1
}

# alive PID: true while PID runs (a zombie, which an init that reaps slowly
# may leave for a while, counts as gone).
alive() {
  local st
  read -r st 2>/dev/null <"/proc/$1/stat" || return 1
  st=${st##*) }
  [[ ${st:0:1} != Z ]]
}

# stop_pid PID NAME [WAIT_S]: SIGTERM, wait up to WAIT_S, then SIGKILL.
stop_pid() {
  local pid=$1 name=$2 wait_s=${3:-$WAIT_EXIT_S} i
  kill -TERM "$pid" 2>/dev/null || return 0
  for ((i = 0; i < wait_s * 10; i++)); do
    alive "$pid" || return 0
    sleep 0.1
  done
  ((wait_s < WAIT_EXIT_S)) ||
    echo "slurm_local: $name (pid $pid) ignored SIGTERM for ${wait_s}s; killing it" >&2
  kill -KILL "$pid" 2>/dev/null || true
  for ((i = 0; i < 50; i++)); do
    alive "$pid" || return 0
    sleep 0.1
  done
  echo "slurm_local: $name (pid $pid) still alive" >&2
  return 1
}

# step_pids DIR: job steps of DIR's cluster and their processes. slurmstepd
# outlives slurmd and rewrites its command line and environment, but keeps
# DIR/log/slurmd.log open; the job's processes are its descendants.
step_pids() {
  local dir=$1 p pid ppid rest found=" " grew=1
  for p in /proc/[0-9]*; do
    find "$p/fd" -lname "$dir/log/slurmd.log" 2>/dev/null | grep -q . || continue
    found+="${p#/proc/} "
  done
  [[ $found == " " ]] && return 0
  while ((grew)); do  # add children until nothing new turns up
    grew=0
    for p in /proc/[0-9]*; do
      pid=${p#/proc/}
      [[ $found == *" $pid "* ]] && continue
      read -r _ rest 2>/dev/null <"$p/stat" || continue
      rest=${rest##*) }  # skip "(comm)", which may hold spaces
      read -r _ ppid _ <<<"$rest"
      [[ $found == *" $ppid "* ]] && { found+="$pid "; grew=1; }
    done
  done
  # Newest first, so the job's processes end before their slurmstepd.
  tr ' ' '\n' <<<"$found" | sed '/^$/d' | tac
}

cmd_stop() {
  local dir=$1 pid ok=0 d i jobs=()
  [[ -d $dir ]] || return 0
  # Cancel jobs first so their steps end cleanly while the daemons still run.
  if pid_for "$dir" "$dir/run/slurmctld.pid" >/dev/null; then
    export SLURM_CONF=$dir/slurm.conf
    mapfile -t jobs < <(timeout 10 squeue -h -o %A 2>/dev/null || true)
    if ((${#jobs[@]})); then
      timeout 10 scancel --full "${jobs[@]}" 2>/dev/null || true
      for ((i = 0; i < 100; i++)); do
        [[ -z $(timeout 5 squeue -h -o %A 2>/dev/null || true) ]] && break
        sleep 0.1
      done
    fi
  fi
  for d in slurmd slurmctld; do
    if pid=$(pid_for "$dir" "$dir/run/$d.pid"); then stop_pid "$pid" "$d" || ok=1; fi
  done
  # slurmstepd ignores SIGTERM, hence the short grace before SIGKILL.
  for pid in $(step_pids "$dir"); do stop_pid "$pid" "job step process" 2 || ok=1; done
  if pid=$(pid_for "$dir" "$dir/run/munged.pid"); then stop_pid "$pid" munged || ok=1; fi
  rm -f "$dir/run/"*.pid
  return $ok
}

# have CMD: true when an executable CMD is on PATH (bash's `command -v` also
# reports a non-executable file).
have() {
  local d
  local IFS=:
  for d in $PATH; do [[ -f $d/$1 && -x $d/$1 ]] && return 0; done
  return 1
}

# free_port TAKEN...: a TCP port below the usual ephemeral range that is not
# in /proc/net/tcp{,6} (any state) and not among TAKEN.
free_port() {
  local used="" local_addr port i
  while read -r _ local_addr _; do
    [[ $local_addr == *:* ]] && used+=" $((16#${local_addr##*:})) "
  done < <(tail -q -n +2 /proc/net/tcp /proc/net/tcp6 2>/dev/null)
  for ((i = 0; i < 200; i++)); do
    port=$((10000 + RANDOM % 22000))
    [[ $used == *" $port "* ]] && continue
    [[ " $* " == *" $port "* ]] && continue
    echo "$port"
    return 0
  done
  return 1
}

# fail STEP LOG: report, show the log's tail, stop everything, exit 1.
fail() {
  local step=$1 log=${2:-}
  echo "slurm_local: start failed: $step" >&2
  if [[ -n $log && -s $log ]]; then
    echo "--- last lines of $log:" >&2
    tail -n 25 "$log" >&2
    echo "---" >&2
  fi
  cmd_stop "$DIR" || true
  exit 1
}

write_conf() {
  local dir=$1 node=$2 cpus=$3 ctld_port=$4 slurmd_port=$5 user
  user=$(id -un)
  : >"$dir/plugstack.conf"
  # Values are quoted so that a DIR with spaces survives slurm.conf parsing.
  cat >"$dir/slurm.conf" <<EOF
# Generated by tests/cluster/slurm_local.sh; lives and dies with this folder.
ClusterName=lsniftest
# 127.0.0.1 so nothing depends on name resolution of this host.
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=$user
SlurmdUser=$user
# Our own munged: slurm talks to it through this socket, not /run/munge.
AuthType=auth/munge
CredType=cred/munge
AuthInfo="socket=$dir/munge.socket"
StateSaveLocation="$dir/state"
SlurmdSpoolDir="$dir/spool"
SlurmctldPidFile="$dir/run/slurmctld.pid"
SlurmdPidFile="$dir/run/slurmd.pid"
SlurmctldLogFile="$dir/log/slurmctld.log"
SlurmdLogFile="$dir/log/slurmd.log"
# An empty SPANK config instead of /etc/slurm/plugstack.conf.
PlugStackConfig="$dir/plugstack.conf"
# No cgroups (containers often lack a writable cgroup tree): track job
# processes through /proc and do no task binding.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
MailProg=/bin/true
# Hand out single CPUs so array tasks run side by side.
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
# A node that was down comes back as soon as its slurmd registers.
ReturnToService=2
# Trust the node line below even if the hardware reports more (nproc may be
# a cgroup/affinity limit), so the node is not drained for a mismatch.
SlurmdParameters=config_overrides
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=512 State=UNKNOWN
PartitionName=debug Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
}

cmd_start() {
  local dir=$1 c node cpus ctld_port slurmd_port state i
  export PATH=$PATH:/usr/sbin:/sbin  # the daemons live there
  for c in munged slurmctld slurmd sbatch sinfo squeue scancel; do
    if ! have "$c"; then
      echo "slurm_local: skip: '$c' is not installed (apt-get install slurm-wlm munge)"
      exit 77
    fi
  done

  if [[ -e $dir && ! -f $dir/.slurm_local ]] && [[ -n $(ls -A "$dir" 2>/dev/null) ]]; then
    die "$dir is not empty and was not made by slurm_local.sh; refusing to use it"
  fi
  # munged refuses a socket path its sockaddr_un cannot hold (107 bytes).
  ((${#dir} + 13 <= 107)) || die "DIR is too long for a unix socket path: $dir"
  mkdir -p "$dir"
  for c in munged slurmctld slurmd; do
    if pid_for "$dir" "$dir/run/$c.pid" >/dev/null; then
      die "$c already runs for $dir; stop it first: $0 stop $(printf %q "$dir")"
    fi
  done
  rm -rf "$dir/state" "$dir/spool" "$dir/run" "$dir/munge.socket"*
  mkdir -p "$dir/state" "$dir/spool" "$dir/run" "$dir/log"
  : >"$dir/.slurm_local"
  # munged wants its directories writable by its user only, the key private,
  # and the socket's directory enterable by all (0711: nobody else may list).
  chmod 0711 "$dir"
  chmod 0700 "$dir/run" "$dir/log"
  rm -f "$dir/munge.key"
  if have mungekey; then
    mungekey --create --keyfile="$dir/munge.key" || fail "mungekey could not create $dir/munge.key"
  else
    dd if=/dev/urandom of="$dir/munge.key" bs=1024 count=1 status=none
  fi
  chmod 0600 "$dir/munge.key"

  # --force: warn instead of quitting when a parent of DIR is not enterable
  # by all users (a 0700 home, say); only our own user talks to this munged.
  timeout 30 munged --force --key-file="$dir/munge.key" --socket="$dir/munge.socket" \
    --pid-file="$dir/run/munged.pid" --log-file="$dir/log/munged.log" \
    --seed-file="$dir/munged.seed" </dev/null >>"$dir/log/munged.log" 2>&1 ||
    fail "munged did not start (exit $?)" "$dir/log/munged.log"
  for ((i = 0; i < 50; i++)); do [[ -S $dir/munge.socket ]] && break; sleep 0.1; done
  [[ -S $dir/munge.socket ]] || fail "munged made no socket at $dir/munge.socket" "$dir/log/munged.log"

  node=$(hostname -s 2>/dev/null || uname -n)
  node=${node%%.*}
  cpus=$(nproc)
  ctld_port=$(free_port) || fail "no free TCP port for slurmctld"
  slurmd_port=$(free_port "$ctld_port") || fail "no free TCP port for slurmd"
  write_conf "$dir" "$node" "$cpus" "$ctld_port" "$slurmd_port"
  export SLURM_CONF=$dir/slurm.conf

  # Both daemonize; their own pid files (run/*.pid) let stop find them.
  # timeout: a daemon stuck before it forks must not hang the test. -c: no
  # state from an earlier run.
  timeout 30 slurmctld -c -f "$SLURM_CONF" </dev/null >>"$dir/log/slurmctld.log" 2>&1 ||
    fail "slurmctld did not start (exit $?)" "$dir/log/slurmctld.log"
  timeout 30 slurmd -c -N "$node" -f "$SLURM_CONF" </dev/null >>"$dir/log/slurmd.log" 2>&1 ||
    fail "slurmd did not start (exit $?)" "$dir/log/slurmd.log"

  # The daemons write their pid files a moment after their parents return.
  for ((i = 0; i < 100; i++)); do
    [[ -s $dir/run/slurmctld.pid && -s $dir/run/slurmd.pid ]] && break
    sleep 0.1
  done
  state=
  for ((i = 0; i < WAIT_IDLE_S * 2; i++)); do
    for c in slurmctld slurmd; do
      pid_for "$dir" "$dir/run/$c.pid" >/dev/null || fail "$c is not running" "$dir/log/$c.log"
    done
    state=$(timeout 5 sinfo -h -n "$node" -o %t 2>/dev/null || true)
    [[ $state == idle ]] && break
    sleep 0.5
  done
  [[ $state == idle ]] ||
    fail "node $node is '${state:-unreachable}', not idle, after ${WAIT_IDLE_S}s" "$dir/log/slurmd.log"

  printf 'export SLURM_CONF=%q\n' "$SLURM_CONF"
  printf '# node %s, %s CPUs, slurmctld port %s, slurmd port %s; stop: %s stop %q\n' \
    "$node" "$cpus" "$ctld_port" "$slurmd_port" "$0" "$dir"
}

[[ $# -eq 2 ]] || usage
[[ -n $2 ]] || usage
# One absolute spelling of DIR (no trailing slash) for pid checks and config.
DIR=$(realpath -m -- "$2")
# slurm.conf quotes paths ("...") and AuthInfo splits at commas.
[[ $DIR =~ ^[[:alnum:]\ ._/+@%:-]+$ ]] ||
  die "DIR may hold only letters, digits, spaces and ._/+@%:- : $DIR"
case $1 in
  start) cmd_start "$DIR" ;;
  stop) cmd_stop "$DIR" ;;
  *) usage ;;
esac
