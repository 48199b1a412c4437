#!/usr/bin/env bash
# The workflow through a real Slurm (docs/workflow.md): installs Debian's slurm-wlm and munge if
# missing, starts a private single-node cluster on localhost (munged, slurmctld and slurmd with
# their own key, config, socket, ports, state and logs in a temporary folder; nothing in /etc is
# used or changed), runs the workflow test that compares a 3-shard workflow with the unsharded
# `radlab run` (tests/workflow/workflow_test.cpp, Workflow.ShardedEqualsUnsharded...) with
# `--profile workflow/profiles/slurm`, prints a summary of what Slurm ran, and stops the daemons
# it started. Needs root. Not part of the default test run.
#
#   scripts/test-slurm.sh [BUILD_DIR]      (default: build; radlab and workflow_tests built there)
#
# Exit 0 when the test passed through Slurm, 1 when it failed, 2 when it could not start.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"

if [ "$(id -u)" -ne 0 ]; then
  echo "test-slurm: needs root (installs packages, starts munged/slurmctld/slurmd)" >&2
  exit 2
fi
if [ ! -x "$build/tests/workflow_tests" ] || [ ! -x "$build/cli/radlab" ]; then
  echo "test-slurm: build radlab and workflow_tests in $build first" >&2
  exit 2
fi

missing=()
for p in slurm-wlm munge snakemake; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "test-slurm: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

dir="$(mktemp -d /tmp/radlab-slurm.XXXXXX)"
chmod 700 "$dir"
mkdir -p "$dir/state" "$dir/spool"
started=()  # pid files of the daemons this script started

stop_daemons() {
  for pidfile in "${started[@]}"; do
    if [ -s "$pidfile" ]; then
      pid="$(cat "$pidfile")"
      kill "$pid" 2>/dev/null || true
      for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    fi
  done
}
trap stop_daemons EXIT

# munge: a fresh key, our own socket.
dd if=/dev/urandom of="$dir/munge.key" bs=1024 count=1 status=none
chmod 400 "$dir/munge.key"
munged --force --socket="$dir/munge.socket" --key-file="$dir/munge.key" \
  --pid-file="$dir/munged.pid" --log-file="$dir/munged.log" --seed-file="$dir/munged.seed"
started+=("$dir/munged.pid")

host="$(hostname -s)"
cpus="$(nproc)"
memory="$(free -m | awk '/^Mem:/ { print int($2 * 0.8) }')"
cat >"$dir/slurm.conf" <<EOF
ClusterName=radlabtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=root
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
SelectTypeParameters=CR_Core_Memory
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
MinJobAge=3600
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$dir/slurm.conf"
slurmctld -f "$SLURM_CONF"
started+=("$dir/slurmctld.pid")
slurmd -f "$SLURM_CONF"
started+=("$dir/slurmd.pid")

for _ in $(seq 60); do
  state="$(sinfo -h -o %T 2>/dev/null || true)"
  [ "$state" = "idle" ] && break
  sleep 1
done
if [ "$state" != "idle" ]; then
  echo "test-slurm: the node did not come up (state '$state'); logs in $dir" >&2
  tail -n 20 "$dir/slurmctld.log" "$dir/slurmd.log" >&2 || true
  exit 2
fi
echo "test-slurm: Slurm $(sinfo -V | awk '{print $2}') up on $host ($cpus CPUs, $memory MB), files in $dir"

export USER="${USER:-root}"  # Snakemake's Slurm executor reads it
status=0
start=$(date +%s)
(cd "$dir" && RADLAB_WORKFLOW_ARGS="--profile $root/workflow/profiles/slurm" \
  "$build/tests/workflow_tests" --gtest_filter='Workflow.ShardedEqualsUnsharded*') \
  >"$dir/test.log" 2>&1 || status=1
echo "test-slurm: the test took $(($(date +%s) - start)) s"
grep -E '^\[ +(OK|FAILED|PASSED|SKIPPED) +\]' "$dir/test.log" || true
[ $status -eq 0 ] || tail -n 60 "$dir/test.log"

# What Slurm ran: every job it still remembers (MinJobAge above keeps them all).
scontrol show jobs -o >"$dir/jobs.txt" 2>/dev/null || true
jobs_total="$(grep -c '^JobId=' "$dir/jobs.txt" || true)"
completed="$(grep -c 'JobState=COMPLETED' "$dir/jobs.txt" || true)"
echo "test-slurm: Slurm ran $jobs_total batch jobs, $completed COMPLETED"
# One line per job: what Snakemake asked for (CPUs, memory, time limit) and what it took.
grep -o 'JobId=[^ ]*\|JobName=[^ ]*\|JobState=[^ ]*\|RunTime=[^ ]*\|TimeLimit=[^ ]*\|NumCPUs=[^ ]*\|MinMemoryNode=[^ ]*' \
  "$dir/jobs.txt" | paste - - - - - - - | sed 's/^/test-slurm:   /' || true
echo "test-slurm: $([ $status -eq 0 ] && echo PASSED || echo FAILED); full log $dir/test.log"
exit $status
