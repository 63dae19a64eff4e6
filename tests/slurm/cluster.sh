#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for the farm test (`make farm-test`).
#   tests/slurm/cluster.sh start DIR   starts munged (if not running), slurmctld and slurmd
#                                      with a minimal slurm.conf in DIR; prints its path,
#                                      to export as SLURM_CONF
#   tests/slurm/cluster.sh stop DIR    stops the two Slurm daemons
# Needs root (the daemons run as root, as the tasks' user is whoever submits), and
# Debian's slurm-wlm and munge (`make farm-deps`).
set -euo pipefail
command=${1:?start or stop}
dir=$(realpath -m "${2:?a folder for the cluster\'s state}")
# A name of our own: `stop` (and a new `start`) also end daemons a crashed test left
# running on our ports, and only ours.
conf=$dir/activeskin-test-slurm.conf

stop() {
    pkill -f -- "-f .*/activeskin-test-slurm.conf" 2>/dev/null || true
    for _ in $(seq 20); do
        pgrep -f -- "-f .*/activeskin-test-slurm.conf" >/dev/null || return 0
        sleep 0.25
    done
}

case $command in
start)
    stop
    rm -rf "$dir/state" "$dir/spool"
    mkdir -p "$dir/state" "$dir/spool" "$dir/log"
    host=$(hostname -s)
    cpus=$(nproc)
    memory=$(awk '/MemTotal/ { print int($2 / 1024) - 1024 }' /proc/meminfo)
    if ! munge -n >/dev/null 2>&1; then
        [ -s /etc/munge/munge.key ] || mungekey --create
        mkdir -p /run/munge
        chown munge:munge /run/munge /etc/munge/munge.key 2>/dev/null || true
        runuser -u munge -- /usr/sbin/munged
    fi
    cat >"$conf" <<CONF
ClusterName=activeskin
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
SlurmctldPort=6917
SlurmdPort=6918
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
ReturnToService=2
NodeName=$host CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
    export SLURM_CONF=$conf
    slurmctld -f "$conf"
    slurmd -f "$conf"
    for _ in $(seq 60); do
        if sinfo -h -o %t 2>/dev/null | grep -qx idle; then
            echo "$conf"
            exit 0
        fi
        sleep 0.5
    done
    echo "the Slurm cluster did not come up; see $dir/log" >&2
    tail -5 "$dir/log/slurmctld.log" "$dir/log/slurmd.log" >&2 || true
    exit 1
    ;;
stop)
    stop
    ;;
*)
    echo "usage: $0 start|stop DIR" >&2
    exit 2
    ;;
esac
