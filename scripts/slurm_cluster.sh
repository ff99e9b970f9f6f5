#!/usr/bin/env bash
# A single-node Slurm cluster for tests, started and stopped without systemd, with everything it
# writes (config, munge key and socket, state, spool, logs, pid files) in one folder.
#
# Usage: scripts/slurm_cluster.sh install
#        scripts/slurm_cluster.sh start DIR
#        scripts/slurm_cluster.sh stop DIR
#        scripts/slurm_cluster.sh wait [--timeout SECONDS] JOBID...
#
#   install  installs Debian's slurmctld slurmd slurm-client munge when one is missing (root or sudo).
#   start    writes DIR/slurm.conf, starts munged, slurmctld and slurmd (as root: slurmd must be),
#            waits until the node is idle and a probe job has run (slurmctld schedules for the first
#            time about 3 s after it starts), and prints 'export SLURM_CONF=DIR/slurm.conf' (also
#            written to DIR/env: 'source DIR/env'). If the cluster cannot start it prints one line
#            'slurm_cluster: cannot start: <reason>' on stderr, stops whatever it had started and
#            exits 1.
#   stop     cancels the cluster's jobs and stops the daemons named by the pid files in DIR (and
#            nothing else); stopping a cluster that is not running is not an error.
#   wait     (SLURM_CONF set, as start prints) polls squeue every 0.5 s until the jobs have left the
#            queue, then prints one line per job, or per array task: 'JOBID STATE EXIT_CODE REASON'
#            (e.g. '12_3 COMPLETED 0:0 None'). Exit 0 when every job COMPLETED, 1 when one ended
#            otherwise (FAILED, CANCELLED, TIMEOUT, ...) or was never run, 2 on timeout (default 300
#            s; the jobs left pending or running are listed as such), 64 on a usage error. A job
#            pending with Reason=DependencyNeverSatisfied is reported as never run at once: this
#            cluster cancels such jobs (DependencyParameters=kill_invalid_depend; Slurm >= 20.02
#            ignores it in SchedulerParameters), another cluster may leave them pending forever. Final states come from
#            'scontrol show job' (the cluster keeps finished jobs for MinJobAge=3600 s) and, for a
#            job it no longer knows, from the job-completion log DIR/jobcomp.log.
#
# The cluster: NodeName = 'hostname -s' at 127.0.0.1, CPUs = nproc, RealMemory = MemTotal of
# /proc/meminfo less 5 % (MiB), one partition 'debug'; select/cons_tres with CR_Core (two 1-CPU
# tasks run at once), proctrack/linuxproc, task/none, no accounting, batch_sched_delay=0 (slurmctld
# still schedules on ticks of a second: an array of 4 on 2 CPUs then a job after it takes 2-3 s). Ports: the
# first free ones from 6817 (controller) and the one after it (slurmd), or SLURM_CLUSTER_PORT
# (controller; slurmd uses the next). SLURM_CLUSTER_MAX_ARRAY_SIZE sets MaxArraySize (default 1001,
# Slurm's). munged runs as root with --force: its key, socket and pid are in DIR/munge, which a
# munge user could not enter when DIR sits in a private (0700) temporary folder, and --force turns
# munged's ownership checks of those paths into warnings. Nothing outside DIR is written.
set -euo pipefail

self=slurm_cluster

die_usage() { echo "$self: $*" >&2; echo "usage: $0 install | start DIR | stop DIR | wait [--timeout S] JOBID..." >&2; exit 64; }

installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }

cmd_install() {
  local packages=(slurmctld slurmd slurm-client munge) missing=() p
  for p in "${packages[@]}"; do installed "$p" || missing+=("$p"); done
  [ ${#missing[@]} -eq 0 ] && return 0
  local sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  echo "diachron: installing ${missing[*]}"
  "${sudo_cmd[@]}" apt-get update -qq
  # Debian's maintainer scripts try to start the services; without systemd they are refused, which
  # is what we want (the cluster is started by 'start DIR').
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

# ---- start / stop --------------------------------------------------------------------------------

port_free() {  # PORT: nothing listens on it (TCP, any address)
  ! ss -Htln "sport = :$1" 2>/dev/null | grep -q .
}

proc_is() {  # PID NAME: PID runs a program whose name starts with NAME (a zombie does not count)
  local stat
  [[ "$1" =~ ^[0-9]+$ ]] || return 1
  stat=$(cat "/proc/$1/stat" 2>/dev/null) || return 1
  # /proc/PID/stat: 'PID (COMM) STATE ...'; a zombie (Z) has stopped, only its parent has not reaped it.
  [[ "$stat" =~ ^[0-9]+\ \((.*)\)\ ([A-Za-z]) ]] || return 1
  [[ "${BASH_REMATCH[1]}" == "$2"* ]] && [ "${BASH_REMATCH[2]}" != Z ] && [ "${BASH_REMATCH[2]}" != X ]
}

pid_of() {  # PIDFILE: its pid, or nothing
  local pid
  pid=$(cat "$1" 2>/dev/null || true)
  [[ "$pid" =~ ^[0-9]+$ ]] && echo "$pid"
  return 0
}

pid_alive() {  # PIDFILE NAME: the pid in PIDFILE runs NAME
  proc_is "$(pid_of "$1")" "$2"
}

stop_pid() {  # PID NAME: TERM, then KILL after 10 s (the daemons remove their pid files at TERM)
  local pid=$1 name=$2 i
  proc_is "$pid" "$name" || return 0
  kill -TERM "$pid" 2>/dev/null || true
  for ((i = 0; i < 100; i++)); do
    proc_is "$pid" "$name" || return 0
    sleep 0.1
  done
  kill -KILL "$pid" 2>/dev/null || true
  sleep 0.1
}

# The job steps of this cluster (slurmstepd processes, which outlive slurmd): those whose
# environment holds this cluster's SLURM_CONF (slurmd is started with it, and passes it on).
cluster_stepds() {  # CONF
  local p
  for p in $(pgrep -x slurmstepd 2>/dev/null || true); do
    if { tr '\0' '\n' <"/proc/$p/environ"; } 2>/dev/null | grep -qxF "SLURM_CONF=$1"; then echo "$p"; fi
  done
}

# The sessions of this cluster's batch scripts (DIR/spool/job*/slurm_script), which only outlive
# their step when the step was killed: one session id per line.
cluster_job_sessions() {  # DIR
  local f p stat
  for f in /proc/[0-9]*/cmdline; do
    p=${f#/proc/}; p=${p%/cmdline}
    if { tr '\0' ' ' <"$f"; } 2>/dev/null | grep -qF "$1/spool/job"; then
      stat=$(cat "/proc/$p/stat" 2>/dev/null) || continue
      stat=${stat##*) }              # after 'PID (COMM) ': STATE PPID PGRP SESSION ...
      read -r _ _ _ sid _ <<<"$stat"
      [ "${sid:-0}" -gt 1 ] && echo "$sid"
    fi
  done | sort -u
}

cmd_stop() {
  local dir conf i p
  [ -d "$1" ] || return 0
  dir=$(cd "$1" && pwd)
  conf="$dir/slurm.conf"
  local ctld slurmd munged
  ctld=$(pid_of "$dir/slurmctld.pid"); slurmd=$(pid_of "$dir/slurmd.pid"); munged=$(pid_of "$dir/munge/munged.pid")
  if proc_is "$ctld" slurmctld && proc_is "$slurmd" slurmd && [ -f "$conf" ]; then
    # Cancel the jobs first: their steps would outlive slurmd.
    local jobs
    jobs=$(SLURM_CONF=$conf timeout 10 squeue -h -o %A 2>/dev/null | sort -u | tr '\n' ' ' || true)
    if [ -n "${jobs// /}" ]; then
      # shellcheck disable=SC2086
      SLURM_CONF=$conf timeout 10 scancel $jobs 2>/dev/null || true
      for ((i = 0; i < 50; i++)); do
        [ -z "$(cluster_stepds "$conf")" ] && break
        sleep 0.1
      done
    fi
  fi
  stop_pid "$slurmd" slurmd
  stop_pid "$ctld" slurmctld
  stop_pid "$munged" munged
  rm -f "$dir/slurmd.pid" "$dir/slurmctld.pid" "$dir/munge/munged.pid"
  # What a killed slurmd left: its steps, then their batch scripts' sessions.
  for p in $(cluster_stepds "$conf"); do kill -KILL "$p" 2>/dev/null || true; done
  local sid pid
  for sid in $(cluster_job_sessions "$dir"); do
    for pid in $(pgrep -s "$sid" 2>/dev/null || true); do kill -KILL "$pid" 2>/dev/null || true; done
  done
  return 0
}

start_failed() {  # DIR REASON
  cmd_stop "$1" || true
  echo "$self: cannot start: $2" >&2
  exit 1
}

last_error() {  # LOGFILE: its last error line, or its last line
  local line
  # (The PMIx lines are noise: Debian's slurmd looks for a PMIx library it does not depend on.)
  line=$(grep -iE 'error|fatal' "$1" 2>/dev/null | grep -viE 'pmix|MPI:' | tail -n 1 || true)
  [ -n "$line" ] || line=$(tail -n 1 "$1" 2>/dev/null || true)
  echo "${line:-no log}"
}

cmd_start() {
  local dir
  mkdir -p "$1" || { echo "$self: cannot start: cannot create $1" >&2; exit 1; }
  dir=$(cd "$1" && pwd)
  local conf="$dir/slurm.conf"
  local b
  for b in munged slurmctld slurmd sinfo squeue sbatch scontrol; do
    command -v "$b" >/dev/null 2>&1 || PATH="$PATH:/usr/sbin:/sbin"
    command -v "$b" >/dev/null 2>&1 || { echo "$self: cannot start: $b is not installed ($0 install)" >&2; exit 1; }
  done
  [ "$(id -u)" -eq 0 ] || { echo "$self: cannot start: slurmd must run as root, and this is uid $(id -u)" >&2; exit 1; }
  if pid_alive "$dir/slurmctld.pid" slurmctld || pid_alive "$dir/slurmd.pid" slurmd ||
     pid_alive "$dir/munge/munged.pid" munged; then
    echo "$self: cannot start: a cluster already runs in $dir ($0 stop $dir)" >&2
    exit 1
  fi

  mkdir -p "$dir/munge" "$dir/state" "$dir/spool" "$dir/log"
  chmod 0711 "$dir/munge"  # clients must reach the socket; the key stays 0600
  # --- munge: its own key and socket ---
  local key="$dir/munge/munge.key" socket="$dir/munge/munge.socket"
  [ ${#socket} -lt 108 ] ||
    start_failed "$dir" "the munge socket path $socket is longer than a Unix socket's 107 characters"
  if [ ! -s "$key" ]; then
    head -c 1024 /dev/urandom >"$key"
  fi
  chmod 0600 "$key"
  rm -f "$socket" "$socket.lock" "$dir/jobcomp.log"
  munged --force --key-file="$key" --socket="$socket" --pid-file="$dir/munge/munged.pid" \
         --log-file="$dir/log/munged.log" --seed-file="$dir/munge/munged.seed" 2>>"$dir/log/munged.log" ||
    start_failed "$dir" "munged: $(last_error "$dir/log/munged.log")"
  local i
  for ((i = 0; i < 50; i++)); do [ -S "$socket" ] && break; sleep 0.1; done
  [ -S "$socket" ] || start_failed "$dir" "munged made no socket: $(last_error "$dir/log/munged.log")"

  # --- slurm.conf ---
  local node cpus mem_mib ctld_port slurmd_port max_array
  node=$(hostname -s)
  cpus=$(nproc)
  mem_mib=$(awk '/^MemTotal:/ { printf "%d", $2 / 1024 * 0.95 }' /proc/meminfo)
  [ "${mem_mib:-0}" -gt 0 ] || mem_mib=1
  max_array=${SLURM_CLUSTER_MAX_ARRAY_SIZE:-1001}
  if ! [[ "$max_array" =~ ^[0-9]+$ ]] || [ "$max_array" -lt 1 ]; then
    start_failed "$dir" "SLURM_CLUSTER_MAX_ARRAY_SIZE must be a whole number >= 1, got '$max_array'"
  fi
  if [ -n "${SLURM_CLUSTER_PORT:-}" ]; then
    ctld_port=$SLURM_CLUSTER_PORT
    if ! [[ "$ctld_port" =~ ^[0-9]+$ ]] || [ "$ctld_port" -lt 1 ] || [ "$ctld_port" -gt 65534 ]; then
      start_failed "$dir" "SLURM_CLUSTER_PORT must be a port number, got '$ctld_port'"
    fi
    if ! port_free "$ctld_port" || ! port_free $((ctld_port + 1)); then
      start_failed "$dir" "SLURM_CLUSTER_PORT: port $ctld_port or $((ctld_port + 1)) is in use"
    fi
  else
    ctld_port=6817
    while ! port_free "$ctld_port" || ! port_free $((ctld_port + 1)); do
      ctld_port=$((ctld_port + 2))
      [ "$ctld_port" -lt 6917 ] || start_failed "$dir" "no two free ports between 6817 and 6917"
    done
  fi
  slurmd_port=$((ctld_port + 1))
  cat >"$conf" <<EOF
# Written by scripts/slurm_cluster.sh start: a single-node test cluster, everything in this folder.
ClusterName=diachron
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$dir/jobcomp.log
SchedulerType=sched/backfill
SchedulerParameters=batch_sched_delay=0
# Since Slurm 20.02 kill_invalid_depend is a DependencyParameter (in SchedulerParameters it is ignored).
DependencyParameters=kill_invalid_depend
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MinJobAge=3600
MaxArraySize=$max_array
MaxJobCount=$((max_array > 10000 ? max_array + 1000 : 10000))
MailProg=/bin/true
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mib State=UNKNOWN
PartitionName=debug Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
  {
    echo "export SLURM_CONF=$conf"
  } >"$dir/env"

  # --- the daemons (they fork and write their pid files) ---
  export SLURM_CONF=$conf
  slurmctld -f "$conf" -c >>"$dir/log/slurmctld.out" 2>&1 ||
    start_failed "$dir" "slurmctld: $(last_error "$dir/log/slurmctld.log")"
  slurmd -f "$conf" -N "$node" >>"$dir/log/slurmd.out" 2>&1 ||
    start_failed "$dir" "slurmd: $(last_error "$dir/log/slurmd.log")"

  # --- until the node is idle (30 s at most) ---
  local state="" deadline=$((SECONDS + 30))
  while [ "$SECONDS" -lt "$deadline" ]; do
    pid_alive "$dir/slurmctld.pid" slurmctld || [ "$SECONDS" -lt 3 ] ||
      start_failed "$dir" "slurmctld stopped: $(last_error "$dir/log/slurmctld.log")"
    state=$(timeout 5 sinfo -h -n "$node" -o %t 2>/dev/null | head -n 1 || true)
    [ "$state" = idle ] && break
    sleep 0.2
  done
  if [ "$state" != idle ]; then
    local why
    if ! pid_alive "$dir/slurmd.pid" slurmd; then why="slurmd stopped: $(last_error "$dir/log/slurmd.log")"
    elif ! pid_alive "$dir/slurmctld.pid" slurmctld; then why="slurmctld stopped: $(last_error "$dir/log/slurmctld.log")"
    else why="node $node is '${state:-unknown}' after 30 s: $(last_error "$dir/log/slurmctld.log")"; fi
    start_failed "$dir" "$why"
  fi
  # --- until a job runs: slurmctld schedules for the first time about 3 s after it starts, and a
  # job proves the whole path (munge credentials, slurmd, the spool) ---
  local probe probe_state=""
  probe=$(timeout 10 sbatch --parsable -J slurm_cluster_probe -o /dev/null -e /dev/null -D "$dir" --wrap true 2>&1) ||
    start_failed "$dir" "sbatch of a probe job failed: $(head -n 1 <<<"$probe")"
  deadline=$((SECONDS + 30))
  while [ "$SECONDS" -lt "$deadline" ]; do
    probe_state=$(timeout 5 scontrol show job -o "$probe" 2>/dev/null | sed -n 's/.*JobState=\([^ ]*\).*/\1/p' || true)
    case "$probe_state" in
      COMPLETED) break ;;
      PENDING | RUNNING | CONFIGURING | COMPLETING | "") sleep 0.2 ;;
      *) start_failed "$dir" "a probe job ended $probe_state: $(last_error "$dir/log/slurmd.log")" ;;
    esac
  done
  [ "$probe_state" = COMPLETED ] ||
    start_failed "$dir" "a probe job is still ${probe_state:-unknown} after 30 s: $(last_error "$dir/log/slurmctld.log")"
  echo "export SLURM_CONF=$conf"
}

# ---- wait ----------------------------------------------------------------------------------------

# Field NAME of a one-line 'scontrol show job -o' record.
field() { sed -n "s/.*\(^\| \)$1=\([^ ]*\).*/\2/p" <<<"$2"; }

# Final records of JOBID from the job-completion log (its tasks, if an array), one line each:
# 'JOBID STATE EXIT_CODE REASON', or nothing.
from_jobcomp() {  # JOBID
  local log="" line id state exitc array task
  [ -n "${SLURM_CONF:-}" ] && log="$(dirname "$SLURM_CONF")/jobcomp.log"
  [ -f "$log" ] || return 0
  while IFS= read -r line; do
    id=$(field JobId "$line"); array=$(field ArrayJobId "$line"); task=$(field ArrayTaskId "$line")
    if [ "$id" = "$1" ] || [ "$array" = "$1" ]; then
      state=$(field JobState "$line"); exitc=$(field ExitCode "$line")
      if [ -n "$array" ] && [ -n "$task" ] && [ "$task" != 4294967294 ]; then id="${array}_$task"; fi
      echo "$id $state ${exitc:-?} None"
    fi
  done <"$log"
}

# 'JOBID STATE EXIT_CODE REASON' for JOBID (one line per array task), from scontrol or the log.
job_lines() {  # JOBID
  local out line id state exitc reason array task
  if out=$(scontrol show job -o "$1" 2>/dev/null) && [ -n "$out" ]; then
    while IFS= read -r line; do
      [ -n "$line" ] || continue
      id=$(field JobId "$line"); array=$(field ArrayJobId "$line"); task=$(field ArrayTaskId "$line")
      [ -n "$array" ] && [ -n "$task" ] && id="${array}_$task"
      state=$(field JobState "$line"); exitc=$(field ExitCode "$line"); reason=$(field Reason "$line")
      echo "$id $state ${exitc:-?} ${reason:-None}"
    done <<<"$out"
    return 0
  fi
  out=$(from_jobcomp "$1")
  if [ -n "$out" ]; then echo "$out"; else echo "$1 UNKNOWN ? no-record"; fi
}

cmd_wait() {
  local timeout_s=300
  local ids=()
  while [ $# -gt 0 ]; do
    case "$1" in
      --timeout) [ $# -ge 2 ] || die_usage "--timeout needs a number of seconds"; timeout_s=$2; shift 2 ;;
      --timeout=*) timeout_s=${1#--timeout=}; shift ;;
      -*) die_usage "unknown option $1" ;;
      *) [[ "$1" =~ ^[0-9]+$ ]] || die_usage "a job id is a number, got '$1'"; ids+=("$1"); shift ;;
    esac
  done
  [[ "$timeout_s" =~ ^[0-9]+(\.[0-9]+)?$ ]] || die_usage "--timeout wants seconds, got '$timeout_s'"
  [ ${#ids[@]} -gt 0 ] || die_usage "wait: no job id"
  [ -n "${SLURM_CONF:-}" ] || die_usage "wait: SLURM_CONF is not set (source DIR/env)"
  local list deadline_ms now_ms active="" never="" line jobid reason out rc
  list=$(IFS=,; echo "${ids[*]}")
  deadline_ms=$(($(date +%s%3N) + ${timeout_s%.*} * 1000))
  while :; do
    # Pending, running, or between the two; what has left these states has finished.
    if out=$(squeue -h -j "$list" -t PD,R,CG,CF,S,RQ,RS,SE,SO,RD -o "%i %T %r" 2>&1); then
      active=""; never=""
      while IFS= read -r line; do
        [ -n "$line" ] || continue
        jobid=${line%% *}; reason=${line##* }
        if [ "$reason" = DependencyNeverSatisfied ]; then never+="$jobid "; else active+="$jobid "; fi
      done <<<"$out"
      [ -z "$active" ] && break
    elif ! grep -q "Invalid job id" <<<"$out"; then
      echo "$self: squeue failed: $(head -n 1 <<<"$out")" >&2
      exit 2
    else
      break  # none of the jobs is known any more: all have finished long ago
    fi
    now_ms=$(date +%s%3N)
    if [ "$now_ms" -ge "$deadline_ms" ]; then
      for jobid in "${ids[@]}"; do job_lines "$jobid"; done
      echo "$self: timeout after $timeout_s s, still in the queue: $active" >&2
      exit 2
    fi
    sleep 0.5
  done
  rc=0
  for jobid in "${ids[@]}"; do
    while IFS= read -r line; do
      echo "$line"
      case "$line" in
        *" COMPLETED 0:0 "*) ;;
        *) rc=1 ;;
      esac
    done < <(job_lines "$jobid")
  done
  if [ -n "$never" ]; then
    echo "$self: never run (a dependency cannot be satisfied): $never" >&2
    rc=1
  fi
  return $rc
}

[ $# -ge 1 ] || die_usage "no subcommand"
sub=$1
shift
case "$sub" in
  install) [ $# -eq 0 ] || die_usage "install takes no argument"; cmd_install ;;
  start) [ $# -eq 1 ] || die_usage "start DIR"; cmd_start "$1" ;;
  stop) [ $# -eq 1 ] || die_usage "stop DIR"; cmd_stop "$1" ;;
  wait) cmd_wait "$@" ;;
  *) die_usage "unknown subcommand $sub" ;;
esac
