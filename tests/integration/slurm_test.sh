#!/usr/bin/env bash
# Batch variants as a Slurm job array, on a real one-node cluster from Debian's packages: munged,
# slurmctld and slurmd started here with a generated slurm.conf on 127.0.0.1 (own ports, own munge
# socket and key, nothing of the machine's configuration touched). `sbatch --array=0-3` of
# `facespace batch --shard auto`, then `facespace batch merge`, must give the folder a single
# process writes, byte for byte; a task killed with SIGKILL and submitted again resumes.
# Skips (exit 77, with a line saying why) only where slurmd cannot run: its packages are not
# installed, or this is not root (slurmd starts jobs as their users, which needs root).
# usage: slurm_test.sh FACESPACE SOURCE_DIR
set -u
bin=$(readlink -f "$1"); src=$(readlink -f "$2")
. "$(dirname "$0")/testlib.sh"
export PATH=$PATH:/usr/sbin:/sbin
for tool in munged slurmctld slurmd sbatch squeue scancel sinfo; do
  if ! command -v $tool >/dev/null; then
    echo "SKIP slurm_end_to_end: $tool is not installed (Debian's munge, slurmctld, slurmd and slurm-client; .ci/dev test installs them)"
    exit 77
  fi
done
if [ "$(id -u)" -ne 0 ]; then
  echo "SKIP slurm_end_to_end: slurmd must start as root to run jobs as their users, and this is uid $(id -u)"
  exit 77
fi

w=$(mktemp -d /tmp/facespace-slurm.XXXXXX)  # 0700: munged refuses folders others can write
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
ctld_port=$(free_port); d_port=$(free_port)
cleanup() {
  for pidfile in "$w/slurmd.pid" "$w/slurmctld.pid" "$w/munged.pid"; do
    [ -s "$pidfile" ] && kill "$(cat "$pidfile")" 2>/dev/null
  done
  sleep 1
  for pidfile in "$w/slurmd.pid" "$w/slurmctld.pid" "$w/munged.pid"; do
    [ -s "$pidfile" ] && kill -9 "$(cat "$pidfile")" 2>/dev/null
  done
  [ -n "${FACESPACE_KEEP:-}" ] || rm -rf "$w"
}
trap cleanup EXIT

# munge: a key of our own and a socket in our folder.
mkdir -p "$w/state" "$w/spool" "$w/log"
dd if=/dev/urandom of="$w/munge.key" bs=1024 count=1 status=none && chmod 400 "$w/munge.key"
munged --force --socket="$w/munge.sock" --key-file="$w/munge.key" --log-file="$w/munged.log" \
  --pid-file="$w/munged.pid" --seed-file="$w/munged.seed" 2>"$w/munged.err"
check "munged starts and a credential round-trips" sh -c "munge -S '$w/munge.sock' -n | unmunge -S '$w/munge.sock' | grep -q 'STATUS: *Success'"

cat >"$w/slurm.conf" <<EOF
ClusterName=facespace-test
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$d_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$w/munge.sock
StateSaveLocation=$w/state
SlurmdSpoolDir=$w/spool
SlurmctldPidFile=$w/slurmctld.pid
SlurmdPidFile=$w/slurmd.pid
SlurmctldLogFile=$w/slurmctld.log
SlurmdLogFile=$w/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SwitchType=switch/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MinJobAge=600
NodeName=fsnode NodeHostname=$(hostname) NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=main Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$w/slurm.conf
slurmctld -f "$SLURM_CONF" && slurmd -f "$SLURM_CONF" -N fsnode
for _ in $(seq 1 60); do sinfo -h -o %T 2>/dev/null | grep -q idle && break; sleep 0.5; done
if ! check "slurmctld and slurmd up: the node is idle" sh -c "sinfo -h -o %T | grep -q idle"; then
  tail -5 "$w/slurmctld.log" "$w/slurmd.log"
  finish; exit 1
fi

# Waits until every task of job $1 has ended (at most $2 seconds). From slurmctld's records
# (kept for MinJobAge): a squeue that times out while the machine is busy is no answer.
wait_job() {
  local states
  for _ in $(seq 1 $(($2 * 5))); do
    if states=$(scontrol -o show job "$1" 2>/dev/null) && [ -n "$states" ] &&
       ! grep -Eq 'JobState=(PENDING|RUNNING|COMPLETING|CONFIGURING|SUSPENDED|REQUEUE)' <<<"$states"; then
      return 0
    fi
    sleep 0.2
  done
  return 1
}

rig=$src/assets/facecap/facecap.glb
args=(--sample uniform --count 400 --seed 11 --active 8 --format glb)
"$bin" batch "$rig" "${args[@]}" --out "$w/single" --quiet 2>/dev/null
job=$(sbatch --parsable --array=0-3 -D "$w" -o "$w/log/%A_%a.out" -J facespace-batch \
  --wrap "'$bin' batch '$rig' ${args[*]} --out '$w/sharded' --shard auto --quiet")
check "sbatch --array=0-3 of facespace batch --shard auto: submitted" sh -c "[ -n '$job' ]"
check "every task of the array ends (within 120 s)" wait_job "$job" 120
check "each of the 4 tasks ran its own shard (1/4..4/4, 100 variants each) and recorded it" sh -c "
  for i in 1 2 3 4; do
    grep -q \"shard \$i/4: 100 variants\" '$w'/log/${job}_\$((i - 1)).out && [ -s '$w/sharded/shard-'\$i'-of-4.json' ] || exit 1
  done"
"$bin" batch merge "$w/sharded" 2>"$w/merge.err"; rc=$?
check "batch merge: exit 0, 4 shards, 400 variants, a manifest line each" sh -c "[ $rc -eq 0 ] && grep -q '4 shards, 400 variants' '$w/merge.err' && [ \$(wc -l < '$w/sharded/manifest.jsonl') -eq 400 ]"
check "merged folder byte-identical to the single process's (400 files, manifest, sheet, batch.json)" diff -r "$w/single" "$w/sharded"

# The documented job script (service/deploy/slurm-batch.sh: --array=0-3, --shards 4), as a user submits it.
"$bin" batch "$rig" --sample uniform --count 80 --seed 7 --active 8 --format glb --out "$w/single_script" --quiet 2>/dev/null
job=$(cd "$w" && sbatch --parsable --export=ALL,FACESPACE="$bin",RIG="$rig",OUT="$w/script",COUNT=80 "$src/service/deploy/slurm-batch.sh")
wait_job "$job" 120
"$bin" batch merge "$w/script" 2>/dev/null
check "the documented job script (service/deploy/slurm-batch.sh), submitted as is: 4 tasks, merged byte-identical" \
  sh -c "[ \$(ls '$w'/facespace-batch-${job}_*.log | wc -l) -eq 4 ] && diff -r '$w/single_script' '$w/script'"

# A task killed mid-run (SIGKILL through Slurm), then submitted again on its own, resumes.
args=(--sample uniform --count 600 --seed 3 --format png --width 256 --height 256)
"$bin" batch "$rig" "${args[@]}" --out "$w/single_png" --quiet 2>/dev/null
cmd="'$bin' batch '$rig' ${args[*]} --out '$w/killed' --shard auto --shards 2"
job=$(sbatch --parsable --array=0-1 -D "$w" -o "$w/log/%A_%a.out" -J facespace-batch --wrap "$cmd")
m="$w/killed/manifest.shard-2-of-2.jsonl"
for _ in $(seq 1 300); do [ -s "$m" ] && [ "$(wc -l <"$m")" -ge 20 ] && break; sleep 0.1; done
scancel --full --signal=KILL "${job}_1"
wait_job "$job" 120
n=$(wc -l <"$m")
check "task 1 SIGKILLed after $n of 300 variants: no record of a finished shard" sh -c "[ $n -ge 20 ] && [ $n -lt 300 ] && [ ! -e '$w/killed/shard-2-of-2.json' ] && [ -s '$w/killed/shard-1-of-2.json' ]"
"$bin" batch merge "$w/killed" 2>"$w/merge.err"
check "batch merge refuses while the killed shard is unfinished, naming it" grep -q "have not finished: 2/2" "$w/merge.err"
job=$(sbatch --parsable --array=1 -D "$w" -o "$w/log/%A_%a.out" -J facespace-batch --wrap "$cmd")
check "the killed task submitted again (sbatch --array=1) finishes" wait_job "$job" 120
check "it resumed: only the variants the kill cut are generated" sh -c "grep -Eq 'shard 2/2: 300 variants in .* \\([0-9]+ generated, ([2-9][0-9]|[1-2][0-9][0-9]) already there\\)' '$w/log/${job}_1.out'"
"$bin" batch merge "$w/killed" 2>/dev/null
check "merged after the rerun: byte-identical to the single process's PNG batch" diff -r "$w/single_png" "$w/killed"
grep -h "already there" "$w"/log/*.out | sed 's/^/  /'
if [ $fail -gt 0 ]; then  # What the tasks and the daemons said, to tell a facespace failure from a Slurm one.
  for f in "$w"/log/*.out "$w"/facespace-batch-*.log; do [ -e "$f" ] && { echo "== $f"; tail -n 5 "$f"; }; done
  tail -n 15 "$w/slurmctld.log" "$w/slurmd.log"
fi
finish
