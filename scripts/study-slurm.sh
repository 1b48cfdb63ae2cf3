#!/usr/bin/env bash
# A Slurm array job running the job list of a pliant study, one array task per line (line K is
# run K, which writes DIR/runs/000K/run.json). Write the list, submit, collect:
#
#   pliant study SCENE --sweep 'PATH=V1|V2|...' --out /shared/DIR --jobs /shared/DIR/jobs.txt
#   sbatch --array=1-$(wc -l < /shared/DIR/jobs.txt) scripts/study-slurm.sh /shared/DIR/jobs.txt
#   pliant study --collect /shared/DIR        # after the array finished
#
# DIR, the scene, its meshes and the pliant binary must be on a file system every node sees
# (the job lines use absolute paths). A run is one process on --threads cores (default 1): ask
# for as many with --cpus-per-task. Limit concurrent tasks with --array=1-N%M. Edit the #SBATCH
# lines for your site (partition, account, time).
#SBATCH --job-name=pliant-study
#SBATCH --cpus-per-task=1
#SBATCH --time=01:00:00
#SBATCH --output=pliant-study-%A_%a.out
set -euo pipefail
jobs=${1:?usage: sbatch --array=1-N study-slurm.sh JOBS_FILE}
task=${SLURM_ARRAY_TASK_ID:?not in a Slurm array job (sbatch --array=1-N)}
line=$(sed -n "${task}p" "$jobs")
[ -n "$line" ] || { echo "study-slurm.sh: $jobs has no line $task" >&2; exit 2; }
exec bash -c "$line"
