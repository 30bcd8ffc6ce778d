# A private single-node Slurm for the tests (sourced): munged, slurmctld and slurmd started as
# root from a temporary folder, on ports of their own, with SLURM_CONF pointing at its
# configuration; `slurm_stop` (also on exit) shuts them down and removes nothing else.
# usage: slurm_start DIR    (exit status 77, a CTest skip, when not root or Slurm is missing)
slurm_start() {
  local dir=$1
  if [ "$(id -u)" -ne 0 ]; then echo "skip: a private Slurm needs root"; exit 77; fi
  for tool in munged slurmctld slurmd sbatch sinfo; do
    command -v "$tool" >/dev/null || { echo "skip: $tool not installed (slurm-wlm, munge)"; exit 77; }
  done
  mkdir -p "$dir/state" "$dir/spool" "$dir/log"
  local port=$((20000 + RANDOM % 20000))
  local node
  node=$(hostname -s)
  munged --force --socket="$dir/munge.sock" --key-file=/etc/munge/munge.key \
    --pid-file="$dir/munged.pid" --log-file="$dir/log/munged.log" --seed-file="$dir/munge.seed" ||
    return 1
  cat > "$dir/slurm.conf" <<CONF
ClusterName=cdfftest
SlurmctldHost=$node
SlurmctldPort=$port
SlurmdPort=$((port + 1))
AuthType=auth/munge
AuthInfo=socket=$dir/munge.sock
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/builtin
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
NodeName=$node NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=cdff Nodes=$node Default=YES MaxTime=INFINITE State=UP
CONF
  export SLURM_CONF=$dir/slurm.conf
  SLURM_STOP_DIR=$dir
  trap slurm_stop EXIT
  slurmctld -f "$SLURM_CONF" || return 1
  slurmd -f "$SLURM_CONF" -N "$node" || return 1
  for _ in $(seq 1 50); do  # up to 10 s for the node to register
    sinfo -h -o %t 2>/dev/null | grep -q idle && return 0
    sleep 0.2
  done
  echo "the private Slurm did not start; its logs:"; tail -n 20 "$dir"/log/*.log
  return 1
}

slurm_stop() {
  [ -n "${SLURM_STOP_DIR:-}" ] || return 0
  scontrol shutdown >/dev/null 2>&1
  sleep 0.5
  for pidfile in slurmd slurmctld munged; do
    [ -f "$SLURM_STOP_DIR/$pidfile.pid" ] && kill "$(cat "$SLURM_STOP_DIR/$pidfile.pid")" 2>/dev/null
  done
  SLURM_STOP_DIR=
}
