# A sweep on a real Slurm: the test starts munge, slurmctld and slurmd on this machine (a one-node
# cluster with this machine's cores, all in a temporary folder, as the current user), submits a small
# config with `photonbench slurm --submit` (a job array of shards and a merge job after it), waits
# for both, and checks the merged run against the same config run here, cell for cell. It skips
# (exit 77) only when the daemons cannot be started, saying why.
source "$(dirname "$0")/lib.bash"
skip() {
  echo "SKIP: $*"
  exit 77
}
for tool in munged slurmctld slurmd sbatch squeue scontrol sinfo; do
  command -v "$tool" > /dev/null ||
    skip "$tool is not installed (scripts/setup.sh installs the Debian packages slurm-wlm and munge)"
done

# munged wants its socket's folders searchable by everyone and writable by no one else.
chmod 755 "$WORK"
cluster="$WORK/cluster"
mkdir -p "$cluster"/{munge,socket,state,spool,log}
chmod 700 "$cluster/munge"
chmod 755 "$cluster/socket"
export SLURM_CONF="$cluster/slurm.conf"
socket="$cluster/socket/munge.socket"
teardown() {
  # Only the daemons this test started, by the pids they wrote.
  [ -s "$cluster/slurmctld.pid" ] && scontrol shutdown > /dev/null 2>&1
  for pidfile in "$cluster/slurmctld.pid" "$cluster/slurmd.pid" "$cluster/munge/munged.pid"; do
    [ -s "$pidfile" ] || continue
    pid=$(cat "$pidfile")
    [ "$pidfile" = "$cluster/munge/munged.pid" ] && kill "$pid" 2> /dev/null
    for _ in $(seq 1 50); do kill -0 "$pid" 2> /dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2> /dev/null
  done
  rm -rf "$WORK"
}
trap teardown EXIT

head -c 1024 /dev/urandom > "$cluster/munge/munge.key"
chmod 600 "$cluster/munge/munge.key"
munged --socket="$socket" --key-file="$cluster/munge/munge.key" --pid-file="$cluster/munge/munged.pid" \
  --log-file="$cluster/munge/munged.log" --seed-file="$cluster/munge/munged.seed" ||
  skip "munged does not start: $(tail -3 "$cluster/munge/munged.log" 2> /dev/null)"

# Free ports for the two daemons (another Slurm on this machine keeps the standard ones).
read -r ctld_port slurmd_port < <(/usr/bin/python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')
host=$(hostname -s)
node=$(slurmd -C | head -1)  # NodeName=<host> CPUs=... RealMemory=...: this machine as slurmd sees it
user=$(id -un)
cat > "$SLURM_CONF" <<CONF
ClusterName=photonbench-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$cluster/state
SlurmdSpoolDir=$cluster/spool
SlurmctldPidFile=$cluster/slurmctld.pid
SlurmdPidFile=$cluster/slurmd.pid
SlurmctldLogFile=$cluster/log/slurmctld.log
SlurmdLogFile=$cluster/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=sweeps Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -i -f "$SLURM_CONF" || skip "slurmctld does not start: $(tail -3 "$cluster/log/slurmctld.log" 2> /dev/null)"
slurmd -f "$SLURM_CONF" || skip "slurmd does not start: $(tail -3 "$cluster/log/slurmd.log" 2> /dev/null)"
for _ in $(seq 1 60); do
  [ "$(sinfo -h -o %T 2> /dev/null)" = "idle" ] && break
  sleep 0.5
done
[ "$(sinfo -h -o %T 2> /dev/null)" = "idle" ] ||
  skip "the node does not come up in 30 s: sinfo '$(sinfo -h -o %T 2>&1)'; $(tail -2 "$cluster/log/slurmctld.log" "$cluster/log/slurmd.log" 2> /dev/null)"
pass "a one-node Slurm is up ($node)"

cfg="$WORK/sweep.yaml"
cat > "$cfg" <<YAML
name: slurm-sweep
resolution: [64, 36]
frames: {warmup: 1, count: 2, metrics_every: 2}
scenes: [cornell-box]
techniques:
  - technique: direct
    params: {shadow_map_size: [64, 128, 256]}
reference: {samples: 16}
YAML
expect_exit 0 "photonbench slurm writes the scripts" -- "$PB" slurm "$cfg" --out "$WORK/dry" --gpus-per-task 1 --cpus-per-task 2
expect_match "... one shard per cell by default" "3 cells in 3 shards" "$OUT"
expect_match "... with the GPUs asked for" "^#SBATCH --gpus-per-task=1$" "$(cat "$WORK/dry/slurm/shards.sbatch")"
expect_match "... and the array" "^#SBATCH --array=1-3$" "$(cat "$WORK/dry/slurm/shards.sbatch")"
expect_exit 2 "more shards than cells is refused" -- "$PB" slurm "$cfg" --out "$WORK/dry" --shards 4
expect_exit 2 "a folder an #SBATCH line cannot hold is refused" -- "$PB" slurm "$cfg" --out "$WORK/a b"
[ ! -e "$WORK/a b" ] && pass "... before anything is written" || fail "$WORK/a b was created"

sweep="$WORK/sweep"
expect_exit 0 "photonbench slurm --submit submits the sweep" -- \
  "$PB" slurm "$cfg" --out "$sweep" --shards 2 --partition sweeps --time 10 --submit
shards_job=$(printf '%s\n' "$OUT" | sed -n 's/^shards_job=//p')
merge_job=$(printf '%s\n' "$OUT" | sed -n 's/^merge_job=//p')
[ -n "$shards_job" ] && [ -n "$merge_job" ] && pass "it prints the job ids ($shards_job, $merge_job)" ||
  fail "no job ids in: $OUT"

# Local run while Slurm works (another working directory: its own reference cache).
mkdir -p "$WORK/local-cwd"
(cd "$WORK/local-cwd" && "$PB" run "$cfg" --out "$WORK/local" > "$WORK/local.log" 2>&1) &&
  pass "the same config runs here" || fail "local run: $(tail -5 "$WORK/local.log")"

for _ in $(seq 1 300); do
  [ -z "$(squeue -h -j "$shards_job,$merge_job" 2> /dev/null)" ] && break
  sleep 1
done
if [ -n "$(squeue -h -j "$shards_job,$merge_job" 2> /dev/null)" ]; then
  fail "the jobs did not end in 300 s: $(squeue -j "$shards_job,$merge_job")"
  scancel "$shards_job" "$merge_job"
fi
states=$( (scontrol show job "$shards_job"; scontrol show job "$merge_job") 2>&1 | grep -o 'JobState=[A-Z]*' | tr '\n' ' ')
[ "$(scontrol show job "$merge_job" | grep -o 'JobState=[A-Z]*')" = "JobState=COMPLETED" ] &&
  [ "$(scontrol show job "$shards_job" | grep -c 'JobState=COMPLETED')" -eq 2 ] &&
  pass "both array tasks and the merge job completed" || fail "job states: $states; $(cat "$sweep"/slurm/*.log)"
expect_match "the merge job reports the merged run" "merge: 2 shards, 3 cells, 0 failed" "$(cat "$sweep/slurm/merge.log")"
compare="$(/usr/bin/python3 "$SRC/tests/e2e/shard_compare_runs.py" "$WORK/local" "$sweep/run")" &&
  pass "the merged run equals the local run: $(echo "$compare" | tail -1)" || fail "merged vs local: $compare"
/usr/bin/python3 - "$sweep/run/run.json" "$shards_job" <<'PY' && pass "run.json records each shard's array task" || fail "run.json shards"
import json, sys
run = json.load(open(sys.argv[1]))
tasks = sorted((s["slurm"]["SLURM_ARRAY_JOB_ID"], s["slurm"]["SLURM_ARRAY_TASK_ID"]) for s in run["shards"])
assert tasks == [(sys.argv[2], "1"), (sys.argv[2], "2")], tasks
PY
[ -n "$(ls "$sweep"/results/reference-cache/*.json 2> /dev/null)" ] &&
  pass "the shards shared the reference cache in the sweep folder" || fail "no shared cache in $sweep"
finish
