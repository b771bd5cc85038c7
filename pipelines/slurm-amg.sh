#!/bin/bash
# Run an ohm pipeline on a Slurm cluster with solver=amg (PETSc + hypre over
# MPI).  Rank 0 reads, voxelizes, writes; every rank solves its slab.
#   sbatch --nodes=4 pipelines/slurm-amg.sh pipelines/head.ohm
# The pipeline's `solve` line must say solver=amg.  Size the job from
# docs/scale.md's model: about 450 bytes per cell per rank for the solver,
# plus rank 0's ~50-90 bytes per cell for the grid, material and outputs.
#SBATCH --job-name=ohm-amg
#SBATCH --ntasks-per-node=2
#SBATCH --cpus-per-task=1
#SBATCH --time=02:00:00
#SBATCH --output=ohm-%j.log
set -euo pipefail
pipeline=${1:?usage: sbatch pipelines/slurm-amg.sh PIPELINE.ohm}
# one OpenBLAS thread per rank: the ranks are the parallelism
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
# Where fresh 4 KiB pages are slow to fault (virtual nodes), 2 MiB pages for the
# whole process can halve a large run; measure once (docs/solvers.md, "Page faults"):
# export GLIBC_TUNABLES=glibc.malloc.hugetlb=1
srun --mpi=pmix ohm run "$pipeline"
