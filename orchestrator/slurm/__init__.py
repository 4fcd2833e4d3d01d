"""SLURM, shared by campaigns (campaign.slurm) and single runs (`demorch submit`).

values: what users give for a job (wall time, partition, account, names, paths), checked before it
reaches a job script. commands: sbatch (submit, read the job id), squeue and sacct (a job's state).
script: the job script of one run. record: the jobs of one run (jobs/record.json). job: what a
submitted job runs: the case, stopped before the time limit and submitted again while unfinished.
"""
