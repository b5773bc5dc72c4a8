#!/bin/bash
# A one-node Slurm cluster on this machine's loopback, for the farm tests:
#   slurm-cluster.sh start DIR   writes DIR/slurm.conf, starts munged, slurmctld and
#                                slurmd (their PIDs in DIR/*.pid), waits for the node
#   slurm-cluster.sh stop DIR    stops those three by PID, and waits for them to go
# Clients use it with SLURM_CONF=DIR/slurm.conf. Needs root (SlurmUser=root), the
# Debian packages slurm-wlm and munge, and nothing else: its own munge key and
# socket, free ports on 127.0.0.1, state and spool in DIR.
set -eu
action=${1:?usage: slurm-cluster.sh start|stop DIR}
dir=${2:?usage: slurm-cluster.sh start|stop DIR}

stop_pid() {  # stop_pid FILE: TERM, then KILL after 10 s
  local file=$1 pid
  [ -s "$file" ] || return 0
  pid=$(cat "$file")
  if kill -0 "$pid" 2>/dev/null; then
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$pid" 2>/dev/null || true
  fi
  rm -f "$file"
}

if [ "$action" = stop ]; then
  # Jobs still running are children of slurmd's slurmstepd: cancel them first.
  if [ -f "$dir/slurm.conf" ] && [ -s "$dir/slurmctld.pid" ] && kill -0 "$(cat "$dir/slurmctld.pid")" 2>/dev/null; then
    SLURM_CONF="$dir/slurm.conf" scancel --quiet --full --user="$(id -un)" 2>/dev/null || true
    sleep 0.5
  fi
  stop_pid "$dir/slurmd.pid"
  stop_pid "$dir/slurmctld.pid"
  stop_pid "$dir/munged.pid"
  exit 0
fi
[ "$action" = start ] || { echo "usage: slurm-cluster.sh start|stop DIR" >&2; exit 2; }
for program in munged slurmctld slurmd sbatch; do
  command -v "$program" >/dev/null || { echo "slurm-cluster.sh: $program not found (apt-get install slurm-wlm munge)" >&2; exit 2; }
done
[ "$(id -u)" = 0 ] || { echo "slurm-cluster.sh: needs root (the test cluster runs as SlurmUser=root)" >&2; exit 2; }

# A cluster left behind by an interrupted run goes first, with its jobs.
"$0" stop "$dir"
rm -rf "$dir/state" "$dir/spool"
mkdir -p "$dir/state" "$dir/spool"
chmod 711 "$dir"
dd if=/dev/urandom of="$dir/munge.key" bs=1024 count=1 status=none
chmod 600 "$dir/munge.key"
munged --force --key-file="$dir/munge.key" --socket="$dir/munge.socket" --pid-file="$dir/munged.pid" \
  --log-file="$dir/munged.log" --seed-file="$dir/munged.seed"

# Two free ports on 127.0.0.1: random ones nothing answers on.
free_port() {
  local port
  while :; do
    port=$(( 20000 + RANDOM % 40000 ))
    [ "$port" != "${1:-0}" ] || continue
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then echo "$port"; return; fi
  done
}
ctld_port=$(free_port)
node_port=$(free_port "$ctld_port")
cpus=$(nproc)
cat > "$dir/slurm.conf" <<CONF
ClusterName=cascadetest
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$node_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge.socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
ReturnToService=2
MinJobAge=3600
NodeName=cascadenode NodeAddr=127.0.0.1 NodeHostname=cascadenode CPUs=$cpus State=UNKNOWN
PartitionName=shots Nodes=cascadenode Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$dir/slurm.conf"
slurmctld -f "$SLURM_CONF" -i
slurmd -f "$SLURM_CONF" -N cascadenode
for _ in $(seq 150); do
  if sinfo -h -o %t 2>/dev/null | grep -qx idle; then echo "slurm-cluster.sh: up, SLURM_CONF=$SLURM_CONF"; exit 0; fi
  sleep 0.2
done
echo "slurm-cluster.sh: the node did not come up in 30 s (see $dir/slurmctld.log, $dir/slurmd.log)" >&2
exit 1
