#!/bin/sh
# slurm-local.sh: a one-node Slurm cluster (slurmctld, slurmd and their
# munged) living entirely under one directory, for the cluster tests and
# for trying pipelines/slurm/ on one machine.  Needs root and Debian's
# slurm-wlm and munge; no systemd, no cgroups.
#
#   sh tests/cluster/slurm-local.sh start DIR   writes DIR/slurm.conf, a munge
#                                               key, starts the daemons and
#                                               waits (bounded) for the node
#                                               to be idle
#   sh tests/cluster/slurm-local.sh stop DIR    stops what start started
#
# Afterwards SLURM_CONF=DIR/slurm.conf makes sbatch, squeue, sinfo and
# scancel talk to this cluster.  start exits 0 when the node is idle, 3 with
# the reason on standard error when Slurm cannot run here (not root,
# packages missing, a daemon that does not come up), 1 otherwise; on any
# failure it stops what it started.  The ports are PM_SLURM_PORT and the
# next one; unset, the first pair from 6917 up on which nothing listens, so
# that daemons left over by a killed run do not answer for this one.

usage() { echo "usage: slurm-local.sh start|stop DIR" >&2; exit 2; }
[ $# -eq 2 ] || usage
cmd=$1
mkdir -p "$2" || exit 1
D=$(cd "$2" && pwd) || exit 1

# port_busy N: something listens on TCP port N (IPv4 or IPv6).
port_busy() {
	cat /proc/net/tcp /proc/net/tcp6 2>/dev/null | awk -v h="$(printf ':%04X' "$1")" \
	    '$4 == "0A" && substr($2, length($2) - 4) == h { f = 1 } END { exit !f }'
}

port=${PM_SLURM_PORT:-}
if [ -z "$port" ]; then
	port=6917
	while { port_busy $port || port_busy $((port + 1)); } && [ $port -lt 7115 ]; do
		port=$((port + 2))
	done
fi

# stop_pid FILE: ends the daemon whose pid FILE holds, waiting up to 10 s.
stop_pid() {
	[ -s "$1" ] || return 0
	p=$(cat "$1")
	if kill "$p" 2>/dev/null; then
		i=0
		while kill -0 "$p" 2>/dev/null && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
		kill -9 "$p" 2>/dev/null
	fi
	rm -f "$1"
}

stop() {
	# Jobs still running (a test interrupted) end first, so that no
	# slurmstepd or job outlives the daemons.
	if [ -s "$D/run/slurmctld.pid" ] && kill -0 "$(cat "$D/run/slurmctld.pid")" 2>/dev/null; then
		jobs=$(SLURM_CONF=$D/slurm.conf squeue -h -o %i 2>/dev/null)
		if [ -n "$jobs" ]; then
			# shellcheck disable=SC2086
			SLURM_CONF=$D/slurm.conf scancel $jobs 2>/dev/null
			i=0
			while [ -n "$(SLURM_CONF=$D/slurm.conf squeue -h -o %i 2>/dev/null)" ] && [ $i -lt 50 ]; do
				sleep 0.2
				i=$((i + 1))
			done
		fi
	fi
	stop_pid "$D/run/slurmd.pid"
	stop_pid "$D/run/slurmctld.pid"
	stop_pid "$D/run/munged.pid"
	return 0
}

skip() { echo "$*" >&2; stop; exit 3; }

start() {
	[ "$(id -u)" = 0 ] || skip "not root (slurmd must run as root)"
	for c in munged slurmctld slurmd sbatch sinfo squeue scancel scontrol; do
		command -v $c >/dev/null 2>&1 ||
		    [ -x /usr/sbin/$c ] || skip "$c not installed (Debian: slurm-wlm and munge)"
	done
	PATH=$PATH:/usr/sbin
	stop
	rm -rf "$D/run" "$D/state" "$D/spool" "$D/log" "$D/munge"
	mkdir -p "$D/run" "$D/state" "$D/spool" "$D/log" "$D/munge" || exit 1
	chmod 700 "$D/munge"
	dd if=/dev/urandom of="$D/munge/munge.key" bs=1024 count=1 2>/dev/null &&
	    chmod 400 "$D/munge/munge.key" || exit 1
	munged -f --socket="$D/munge/munge.sock" --key-file="$D/munge/munge.key" \
	    --pid-file="$D/run/munged.pid" --log-file="$D/log/munged.log" \
	    --seed-file="$D/munge/munged.seed" 2>"$D/log/munged.err" ||
	    skip "munged does not start: $(tail -n 1 "$D/log/munged.err")"

	node=$(slurmd -C 2>/dev/null | sed -n 's/^\(NodeName=.*\)/\1/p')
	[ -n "$node" ] || skip "slurmd -C names no node"
	name=$(echo "$node" | sed 's/^NodeName=\([^ ]*\).*/\1/')
	cat >"$D/slurm.conf" <<CONF
# A one-node cluster written by tests/cluster/slurm-local.sh.
ClusterName=pmtest
SlurmctldHost=$name(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$D/munge/munge.sock
StateSaveLocation=$D/state
SlurmdSpoolDir=$D/spool
SlurmctldPidFile=$D/run/slurmctld.pid
SlurmdPidFile=$D/run/slurmd.pid
SlurmctldLogFile=$D/log/slurmctld.log
SlurmdLogFile=$D/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SwitchType=switch/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
ReturnToService=2
KillWait=2
MinJobAge=600
InactiveLimit=0
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=pm Nodes=$name Default=YES MaxTime=INFINITE State=UP
CONF
	slurmctld -f "$D/slurm.conf" 2>"$D/log/slurmctld.err" ||
	    skip "slurmctld does not start: $(tail -n 1 "$D/log/slurmctld.err")"
	slurmd -f "$D/slurm.conf" -N "$name" 2>"$D/log/slurmd.err" ||
	    skip "slurmd does not start: $(tail -n 1 "$D/log/slurmd.err")"
	export SLURM_CONF="$D/slurm.conf"
	i=0
	while [ $i -lt 60 ]; do
		s=$(sinfo -h -n "$name" -o %t 2>/dev/null)
		[ "$s" = idle ] && return 0
		sleep 0.5
		i=$((i + 1))
	done
	skip "node $name not idle after 30 s (sinfo: '${s:-nothing}'; see $D/log)"
}

case $cmd in
start) start ;;
stop) stop ;;
*) usage ;;
esac
