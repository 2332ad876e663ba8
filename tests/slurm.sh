#!/usr/bin/env bash
# A real Slurm on this machine runs the lab's sweeps as job arrays, with the scripts of
# examples/slurm/, and the merged reports are checked against unsharded runs.
#
# It installs Debian's slurm-wlm and munge (apt-get; root), writes a one-node
# slurm.conf for this host in a scratch folder, starts munged, slurmctld and slurmd on
# loopback (its own socket, ports and state: nothing under /etc is touched), and then:
#   1. submits part of the extremes suite (--filter "$FILTER") as an array of 4 tasks
#      and the dependent merge (afterok): stability.md is byte-identical to the
#      unsharded run's; the same for the quick suite's pendulum (results.csv, whose
#      timing columns aside) and for a tune search (solver.toml, the pick);
#   2. requeues one finished task (Slurm reruns it): its shard file is replaced whole
#      and the merge still gives the same bytes;
#   3. cancels one task of a held array (scancel): the afterok merge is cancelled, and
#      a merge submitted with afterany fails with exit 2 and one line naming the
#      missing shard;
#   4. lets a second array write into the first one's folder: its merge fails with one
#      line naming the shard of the other run.
# Every wait is bounded (SLURM_TEST_TIMEOUT seconds each, 300 by default). The daemons
# it started are stopped on exit, whatever happens. It needs the release binary
# (cargo build --release), or SANDBOX2D naming one.
#
#   sudo tests/slurm.sh           # SLURM_TEST_FILTER="" for the whole extremes suite
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$PWD
started=$(date +%s)

bin=${SANDBOX2D:-$repo/target/release/sandbox2d}
filter=${SLURM_TEST_FILTER-_}
timeout=${SLURM_TEST_TIMEOUT:-300}
ctld_port=${SLURM_TEST_PORT:-6817}
slurmd_port=$((ctld_port + 1))

say() { echo "slurm test: $*"; }
fail() {
  echo "slurm test: FAILED: $*" >&2
  exit 1
}

if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null; then
  # CI runs as root on Debian: there, not being able to run is a failure
  if [ "${CI:-}" = true ]; then
    fail "needs root and apt-get (CI=true)"
  fi
  say "skipped: needs root and apt-get to install and run Slurm (run it as root)"
  exit 0
fi
[ -x "$bin" ] || fail "$bin is not built (cargo build --release)"

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
  || ! command -v munged >/dev/null || ! command -v sbatch >/dev/null; then
  say "installing slurm-wlm and munge"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/sandbox2d-slurm.XXXXXX")
chmod 755 "$work"
mkdir -p "$work/munge" "$work/state" "$work/spool" "$work/runs" "$work/logs"
chmod 700 "$work/munge"

# Stops what this script started (by the pids it recorded), then shows the logs on a
# failure and removes the scratch folder.
cleanup() {
  local rc=$?
  set +e
  if [ -f "$work/slurm.conf" ] && [ -f "$work/slurmctld.pid" ]; then
    # our cluster's jobs first, so that no job step outlives its slurmd
    export SLURM_CONF=$work/slurm.conf
    scancel --quiet --user=root 2>/dev/null
    for _ in $(seq 20); do
      [ -z "$(squeue -h 2>/dev/null)" ] && break
      sleep 0.5
    done
  fi
  for d in slurmd slurmctld munged; do
    if [ -f "$work/$d.pid" ]; then
      local pid
      pid=$(cat "$work/$d.pid")
      kill "$pid" 2>/dev/null
      for _ in $(seq 50); do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.1
      done
      kill -9 "$pid" 2>/dev/null
    fi
  done
  # what the daemons left: job steps (slurmstepd) and jobs of this cluster, found by
  # their environment, which names its slurm.conf
  local p
  for p in /proc/[0-9]*; do
    [ "${p#/proc/}" = $$ ] && continue
    if tr '\0' '\n' 2>/dev/null <"$p/environ" | grep -qx "SLURM_CONF=$work/slurm.conf"; then
      kill -9 "${p#/proc/}" 2>/dev/null
    fi
  done
  if [ "$rc" != 0 ]; then
    for f in "$work"/logs/*.log; do
      echo "--- $f (last 30 lines)" >&2
      tail -n 30 "$f" >&2
    done
  fi
  rm -rf "$work"
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# munge: a key of our own, a socket of our own
dd if=/dev/urandom of="$work/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$work/munge/munge.key"
munged --force --key-file="$work/munge/munge.key" --socket="$work/munge/socket" \
  --pid-file="$work/munged.pid" --log-file="$work/logs/munged.log" \
  --seed-file="$work/munge/seed" >>"$work/logs/munged.log" 2>&1

node=$(hostname -s)
cpus=$(nproc)
mem=$(awk '/MemTotal/ { print int($2 / 1024 / 2) }' /proc/meminfo)
cat >"$work/slurm.conf" <<EOF
ClusterName=sandbox2d
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
AuthInfo=socket=$work/munge/socket
CryptoType=crypto/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/logs/slurmctld.log
SlurmdLogFile=$work/logs/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/pgid
TaskPlugin=task/none
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/filetxt
JobCompLoc=$work/logs/jobcomp.log
MinJobAge=3600
KillWait=5
MailProg=/bin/true
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=ci Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$work/slurm.conf

slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF" -N "$node"

# Waits until `$@` succeeds, up to $limit seconds ($timeout unless set).
wait_for() {
  local what=$1
  shift
  local t0 bound=${limit:-$timeout}
  t0=$(date +%s)
  until "$@"; do
    if [ $(($(date +%s) - t0)) -ge "$bound" ]; then
      fail "$what: not after $bound s"
    fi
    sleep 1
  done
}
node_idle() { sinfo -h -n "$node" -o %T 2>/dev/null | grep -qx idle; }
limit=60 wait_for "the node to come up (ports $ctld_port and $slurmd_port free?)" node_idle
say "one node up: $(sinfo -h -o '%P %D %T %C' | head -1) (partition nodes state cpus A/I/O/T)"

# A job's state (of an array task: JOBID_INDEX), as scontrol shows it; empty when
# Slurm has no record of it (a pending array task cancelled before it ran).
job_state() {
  scontrol -o show job "$1" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | head -1 | cut -d= -f2 || true
}
# Whether none of the jobs given is pending or running.
all_done() {
  local j
  for j in "$@"; do
    if squeue -h -j "$j" -t PENDING,RUNNING,CONFIGURING,COMPLETING,REQUEUED 2>/dev/null | grep -q .; then
      return 1
    fi
  done
}
wait_jobs() { wait_for "jobs $* to end" all_done "$@"; }
# sacct's lines for the jobs given (from the job completion log: no slurmdbd here, so
# array tasks show under their own job ids; scontrol's lines give JOBID_INDEX).
show_sacct() {
  local raw j
  raw=$(for j in "$@"; do
    scontrol -o show job "$j" 2>/dev/null | grep -o '^JobId=[0-9]*' | cut -d= -f2
  done | sort -n | paste -sd,)
  echo "  sacct -c -j $raw:"
  sacct -c -j "$raw" -o JobID,JobName%16,Partition,NodeList,State,ExitCode 2>/dev/null \
    | sed 's/^/    /'
  echo "  scontrol show job (array ids):"
  for j in "$@"; do
    scontrol -o show job "$j" 2>/dev/null \
      | grep -o -E '^JobId=[0-9]+|ArrayJobId=[0-9]+|ArrayTaskId=[0-9]+|JobName=[^ ]+|JobState=[A-Z_]+|Reason=[^ ]+|ExitCode=[0-9:]+' \
      | paste -sd' ' | sed 's/^/    /'
  done
}
expect_state() {
  local s
  s=$(job_state "$1")
  [ "$s" = "$2" ] || fail "job $1 is ${s:-gone}, not $2 (see $work/runs/slurm-$1.out)"
}

export SANDBOX2D=$bin RESULTS=$work/runs
submit() {
  # sbatch's --parsable prints JOBID[;CLUSTER]
  local id
  id=$(sbatch --parsable --chdir="$work/runs" "$@")
  echo "${id%%;*}"
}
shard=$repo/examples/slurm/shard.sbatch
merge=$repo/examples/slurm/merge.sbatch
out_of() { echo "--output=$work/runs/slurm-%A_%a.out"; }

# -------- 1. three sweeps, each an array of 4 and its merge --------
extremes=(bench --suite extremes)
[ -n "$filter" ] && extremes+=(--filter "$filter")
quick=(bench --suite quick --filter pendulum --steps 60 --repeats 1)
tune=(tune stack --budget-ms 1e9 --metric penetration --steps 60 --rounds 1)

say "unsharded runs (on this machine, outside Slurm)"
"$bin" "${extremes[@]}" --out "$work/whole-extremes" >/dev/null
"$bin" "${quick[@]}" --out "$work/whole-quick" >/dev/null
"$bin" "${tune[@]}" --out "$work/whole-tune" >/dev/null

a=$(submit --array=0-3 "$(out_of)" "$shard" "${extremes[@]}")
ma=$(submit --dependency=afterok:"$a" --output="$work/runs/slurm-%j.out" "$merge" "$a" bench)
q=$(submit --array=0-3 "$(out_of)" "$shard" "${quick[@]}")
mq=$(submit --dependency=afterok:"$q" --output="$work/runs/slurm-%j.out" "$merge" "$q" bench)
t=$(submit --array=0-3 "$(out_of)" "$shard" "${tune[@]}")
mt=$(submit --dependency=afterok:"$t" --output="$work/runs/slurm-%j.out" "$merge" "$t" tune)
say "submitted: extremes array $a + merge $ma, quick array $q + merge $mq, tune array $t + merge $mt"
echo "  squeue:"
squeue -o '%.10i %.9P %.16j %.8u %.2t %.8M %.5D %R' | sed 's/^/    /'
# the first tasks to run (a task of this size takes a second or two)
for _ in $(seq 100); do
  squeue -h -t RUNNING | grep -q . && break
  sleep 0.2
done
echo "  squeue, once tasks run:"
squeue -o '%.10i %.9P %.16j %.8u %.2t %.8M %.5D %R' | sed 's/^/    /'
wait_jobs "$a" "$ma" "$q" "$mq" "$t" "$mt"
for j in "$ma" "$mq" "$mt"; do
  expect_state "$j" COMPLETED
done
for i in 0 1 2 3; do
  expect_state "${a}_$i" COMPLETED
  expect_state "${q}_$i" COMPLETED
  expect_state "${t}_$i" COMPLETED
done
show_sacct "${a}_0" "${a}_1" "${a}_2" "${a}_3" "$ma"

cmp "$work/runs/$a/stability.md" "$work/whole-extremes/stability.md" \
  || fail "the merged stability.md differs from the unsharded run's"
say "stability.md: cmp finds the array's merge and the unsharded run byte-identical ($(wc -c <"$work/runs/$a/stability.md") bytes, $(grep -c '^| ' "$work/runs/$a/stability.md") table lines)"
sha256sum "$work/runs/$a/stability.md" "$work/whole-extremes/stability.md" | sed "s|$work/|    |"
# results.csv: every column but the timings (ms_*), which no two runs share
no_timings() {
  awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) keep[i] = ($i !~ /^ms_/) }
    { line = ""; for (i = 1; i <= NF; i++) if (keep[i]) line = line $i ","; print line }' "$1"
}
cmp <(no_timings "$work/runs/$q/results.csv") <(no_timings "$work/whole-quick/results.csv") \
  || fail "the merged results.csv differs from the unsharded run's (timings aside)"
say "results.csv: byte-identical but for the timing columns ($(($(wc -l <"$work/runs/$q/results.csv") - 1)) rows)"
cmp "$work/runs/$t/solver.toml" "$work/whole-tune/solver.toml" \
  || fail "the merged tune picked another setting than the unsharded tune"
grep -q "ran in 4 shards (\`--shard\`, run $t)" "$work/runs/$t/tune.md" \
  || fail "tune.md does not say its grid ran in 4 shards"
say "tune: the merged search picks what the unsharded one does ($(grep -m1 '^kind' "$work/runs/$t/solver.toml"), $(grep -m1 '^substeps' "$work/runs/$t/solver.toml"))"

# -------- 2. Slurm reruns a finished task: its shard is replaced whole --------
f=$work/runs/$a/results.shard-2-of-4.json
inode=$(stat -c %i "$f")
scontrol requeue "${a}_1"
# a requeued job waits before it is eligible again; start it now
scontrol update JobId="${a}_1" StartTime=now
wait_for "task ${a}_1 to run again" sh -c "[ \"\$(stat -c %i '$f')\" != $inode ]"
wait_jobs "${a}_1"
expect_state "${a}_1" COMPLETED
grep -q "\"run\": \"$a\"" "$f" || fail "the rerun's shard lost its run id"
for leftover in "$work/runs/$a"/.*.tmp; do
  [ -e "$leftover" ] && fail "a temporary file was left: $leftover"
done
"$bin" bench --merge "$work/runs/$a" --run-id "$a" --out "$work/remerged" >/dev/null
cmp "$work/remerged/stability.md" "$work/whole-extremes/stability.md" \
  || fail "after the rerun the merge differs"
say "requeued ${a}_1: its shard was replaced (inode $inode -> $(stat -c %i "$f")) and the merge is the same bytes"

# -------- 3. a cancelled task: the merge refuses, naming the missing shard --------
c=$(submit --hold --array=0-3 "$(out_of)" "$shard" "${extremes[@]}")
scancel "${c}_2"
scontrol release "$c"
mc=$(submit --dependency=afterok:"$c" --output="$work/runs/slurm-%j.out" "$merge" "$c" bench)
mc_any=$(submit --dependency=afterany:"$c" --output="$work/runs/slurm-%j.out" "$merge" "$c" bench)
wait_jobs "$c" "$mc" "$mc_any"
# the pending task, cancelled, is gone from the array
[ -z "$(job_state "${c}_2")" ] || fail "task ${c}_2 is $(job_state "${c}_2"), not cancelled"
expect_state "$mc" CANCELLED
expect_state "$mc_any" FAILED
scontrol -o show job "$mc_any" | grep -q 'ExitCode=2:0' || fail "merge $mc_any did not exit 2"
err=$(grep '^error:' "$work/runs/slurm-$mc_any.out")
[ "$(echo "$err" | wc -l)" = 1 ] || fail "the merge said more than one line: $err"
case $err in
  *"shard 3/4 of run $c missing"*) ;;
  *) fail "the merge's refusal does not name shard 3/4: $err" ;;
esac
[ -e "$work/runs/$c/stability.md" ] && fail "a refused merge wrote stability.md"
show_sacct "${c}_0" "${c}_1" "${c}_3" "$mc" "$mc_any"
say "cancelled ${c}_2: merge $mc (afterok) was cancelled; merge $mc_any (afterany) exit 2: $err"

# -------- 4. a second array writes into the first one's folder --------
b=$(OUT=$work/runs/$a submit --array=0-1 "$(out_of)" "$shard" "${extremes[@]}")
mb=$(OUT=$work/runs/$a submit --dependency=afterok:"$b" --output="$work/runs/slurm-%j.out" \
  "$merge" "$b" bench)
wait_jobs "$b" "$mb"
expect_state "${b}_1" COMPLETED
expect_state "$mb" FAILED
err=$(grep '^error:' "$work/runs/slurm-$mb.out")
case $err in
  *"is a shard of run $a, not of run $b"*) ;;
  *) fail "the merge of two arrays in one folder said: $err" ;;
esac
show_sacct "${b}_0" "${b}_1" "$mb"
say "two arrays in one folder: merge $mb exit 2: $err"

say "passed in $(($(date +%s) - started)) s"
