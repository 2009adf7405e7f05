#!/usr/bin/env bash
# A single-node SLURM on this machine, for tests/test_cluster.py (docs/guide/slurm.md):
# munge + slurmctld + slurmd as root, ProctrackType=proctrack/linuxproc, TaskPlugin=task/none,
# no accounting storage, one partition "ced" with this node and 2 CPUs, real memory from free -m.
# Installs slurm-wlm and munge with apt-get if missing (needs root). Idempotent: a running
# cluster started by this script is stopped first (stop_slurm.sh).
set -euo pipefail
HERE="$(cd "$(dirname "$0")" && pwd)"
STATE="${CED_SLURM_STATE:-/tmp/ced-slurm}"
[ "$(id -u)" = 0 ] || { echo "start_slurm.sh: needs root (apt-get, munged, slurmd)" >&2; exit 2; }

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get install -y -q slurm-wlm munge >/dev/null 2>&1 \
        || { apt-get update -q >/dev/null && apt-get install -y -q slurm-wlm munge >/dev/null; }
fi

"$HERE/stop_slurm.sh" >/dev/null 2>&1 || true
mkdir -p "$STATE"/{ctld,slurmd,log} /etc/slurm /run/munge /var/log/munge /var/lib/munge /etc/munge

# munge: a key, and a daemon of our own (pid file in $STATE).
[ -s /etc/munge/munge.key ] || dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 2>/dev/null
chown -R munge:munge /etc/munge /run/munge /var/log/munge /var/lib/munge 2>/dev/null || true
chmod 0700 /etc/munge; chmod 0400 /etc/munge/munge.key
runuser -u munge -- munged --pid-file=/run/munge/munged.pid \
    || munged --force --pid-file=/run/munge/munged.pid
cp /run/munge/munged.pid "$STATE/munged.pid"
munge -n | unmunge >/dev/null

NODE="$(hostname -s)"
MEM="$(free -m | awk '/^Mem:/ {print $2}')"
MEM=$((MEM * 9 / 10))  # leave the OS some room; slurmd refuses a node with less than it says
cat > /etc/slurm/slurm.conf <<CONF
# Written by tests/cluster/start_slurm.sh: single-node test cluster.
ClusterName=ced
SlurmctldHost=${NODE}(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
ReturnToService=2
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
StateSaveLocation=$STATE/ctld
SlurmdSpoolDir=$STATE/slurmd
SlurmctldPidFile=$STATE/slurmctld.pid
SlurmdPidFile=$STATE/slurmd.pid
SlurmctldLogFile=$STATE/log/slurmctld.log
SlurmdLogFile=$STATE/log/slurmd.log
SlurmctldPort=6817
SlurmdPort=6818
MinJobAge=300
NodeName=${NODE} NodeAddr=127.0.0.1 CPUs=2 RealMemory=${MEM} State=UNKNOWN
PartitionName=ced Nodes=${NODE} Default=YES MaxTime=INFINITE State=UP
CONF

slurmctld -i
slurmd
for _ in $(seq 60); do
    if sinfo -h -N -o "%N %t" 2>/dev/null | grep -qw idle; then
        sinfo -N -l
        exit 0
    fi
    sleep 1
done
echo "start_slurm.sh: node not idle after 60 s" >&2
sinfo -N -l >&2 || true
tail -20 "$STATE/log/slurmctld.log" "$STATE/log/slurmd.log" >&2 || true
exit 1
