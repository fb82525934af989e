#!/usr/bin/env bash
# Installs and starts a real single-node Slurm on this (Debian) machine, as root: munge,
# slurmctld and slurmd from Debian's packages, one node with every core, one partition.
# For CI (.ci/run calls it) and for trying the array scripts on a workstation. Idempotent: a
# second run finds the daemons up and returns at once.
#
# What these machines need (checked): /run/munge must exist and belong to munge, and munged
# must run as munge; no cgroups, so ProctrackType=proctrack/linuxproc (processes tracked by
# their parent), TaskPlugin=task/none and no cgroup.conf. Without systemd the daemons are
# started directly.
set -euo pipefail

if [ "$(id -u)" != 0 ]; then
    echo "local-setup.sh: must run as root (it installs packages and starts daemons)" >&2
    exit 1
fi
up() { scontrol ping 2> /dev/null | grep -q UP && sinfo -h -o '%T' 2> /dev/null | grep -qE '^(idle|mixed|allocated)'; }
if command -v scontrol > /dev/null && up; then
    echo "local-setup.sh: Slurm is already up"
    exit 0
fi

if ! command -v slurmctld > /dev/null || ! command -v slurmd > /dev/null || ! command -v sbatch > /dev/null || ! command -v munged > /dev/null; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge > /dev/null
fi

# munge: a key (the package makes one), its run directory owned by munge, the daemon as munge.
if [ ! -s /etc/munge/munge.key ]; then
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1 count=1024 status=none
fi
chown munge:munge /etc/munge/munge.key
chmod 400 /etc/munge/munge.key
install -d -o munge -g munge -m 0755 /run/munge /var/log/munge /var/lib/munge
if ! pgrep -u munge -x munged > /dev/null; then
    runuser -u munge -- /usr/sbin/munged
fi
for _ in $(seq 50); do munge -n > /dev/null 2>&1 && break; sleep 0.1; done
munge -n | unmunge > /dev/null

host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 ))
install -d -m 0755 /var/lib/slurm/slurmctld /var/lib/slurm/slurmd /var/log/slurm
cat > /etc/slurm/slurm.conf <<CONF
# Written by deploy/slurm/local-setup.sh: one node, every core, no cgroups.
ClusterName=sdfmo-local
SlurmctldHost=${host}
AuthType=auth/munge
SlurmUser=root
SlurmdUser=root
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
StateSaveLocation=/var/lib/slurm/slurmctld
SlurmdSpoolDir=/var/lib/slurm/slurmd
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
# A killed shard is resubmitted by its owner, not requeued behind its back.
JobRequeue=0
KillWait=5
MinJobAge=600
NodeName=${host} CPUs=${cpus} RealMemory=${mem_mb} State=UNKNOWN
PartitionName=local Nodes=${host} Default=YES MaxTime=INFINITE State=UP
CONF
rm -f /etc/slurm/cgroup.conf

pgrep -x slurmctld > /dev/null || slurmctld
pgrep -x slurmd > /dev/null || slurmd
for _ in $(seq 100); do
    if up; then
        echo "local-setup.sh: Slurm is up ($(sinfo -h -o '%N %c CPUs %T'))"
        exit 0
    fi
    # A node that was down when slurmctld started comes back with an explicit resume.
    scontrol update nodename="${host}" state=resume > /dev/null 2>&1 || true
    sleep 0.2
done
echo "local-setup.sh: Slurm did not come up; last lines of the logs:" >&2
tail -n 20 /var/log/slurm/slurmctld.log /var/log/slurm/slurmd.log >&2 || true
exit 1
