"""A study over seeds on the console and in ensemble.md: each seed, the mean, the range, the references.

`demorch avalanche` and `demorch collapse run` with a study that has `seeds:` launch it here (its
seeds as a campaign's points, campaign.ensemble); `demorch campaign run` prints the same table for
every point of a study campaign run over several seeds.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from orchestrator.case import CaseError
from orchestrator.cli.common import console, errors, fail, run_options
from orchestrator.studies.base import EnsembleRow

MAX_SEED_COLUMNS = 6  # more seeds than this: only the mean and the range are shown (every seed is in ensemble.json)
ENSEMBLE_PAGE = "ensemble.md"


def _number(value: float) -> str:
    return f"{value:.4g}"


def _columns(rows: list[EnsembleRow]) -> tuple[list[int], list[str]]:
    seeds = sorted({seed for row in rows for seed in row[1]})
    shown = seeds if len(seeds) <= MAX_SEED_COLUMNS else []
    return shown, ["metric", *(f"seed {seed}" for seed in shown), "mean", "range", "reference", "check"]


def _cells(row: EnsembleRow, shown: list[int]) -> list[str]:
    name, values, mean, low, high, reference, verdict = row
    return [name, *(_number(values[seed]) if seed in values else "–" for seed in shown), _number(mean), f"{_number(low)} – {_number(high)}",
            reference, verdict]


def ensemble_table(title: str, rows: list[EnsembleRow]) -> Table:
    """The rows as a console table: a column per seed (up to MAX_SEED_COLUMNS), the mean, the range,
    and the reference and check beside the mean."""
    shown, header = _columns(rows)
    table = Table(title=title, header_style="bold")
    for column in header:
        table.add_column(column, justify="left" if column in ("metric", "reference", "check") else "right")
    for row in rows:
        table.add_row(*_cells(row, shown))
    return table


def ensemble_markdown(title: str, rows: list[EnsembleRow]) -> str:
    """The same table in Markdown (ensemble.md)."""
    shown, header = _columns(rows)
    lines = [f"## {title}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell.replace("|", "\\|") for cell in _cells(row, shown)) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def _title(name: str, parameters: dict[str, Any], seeds: int) -> str:
    varied = ", ".join(f"{key} = {value}" for key, value in parameters.items())
    return f"{name}{f' ({varied})' if varied else ''}: {seeds} seed{'s' if seeds != 1 else ''}"


def report_ensembles(campaign_dir: Path, kind_name: str, name: str, always: bool = False) -> int:
    """Print each group's table (every group, or with `always` off only groups of two seeds or
    more), write them to ensemble.md and ensemble.json; return how many members failed."""
    from orchestrator.campaign.ensemble import gather, write_ensembles
    from orchestrator.studies.registry import launch_kind

    kind = launch_kind(kind_name)
    if not hasattr(kind, "ensemble_rows"):  # a plain case has no study report
        return 0
    groups = gather(campaign_dir)
    write_ensembles(campaign_dir, groups, kind)
    pages, failed = [], 0
    for group in groups:
        failed += sum(member.status == "failed" for member in group.members)
        reports = group.reports
        if not reports or (len(group.members) < 2 and not always):
            continue
        try:
            rows = kind.ensemble_rows(reports)  # type: ignore[attr-defined]
        except CaseError as error:
            errors.print(f"[red]error:[/] {error}", markup=True, highlight=False)
            continue
        title = _title(name, group.parameters, len(reports))
        console.print(ensemble_table(title, rows))
        missing = [f"{member.seed} ({member.status})" for member in group.members if member.report is None]
        if missing:
            console.print(f"[yellow]not in the table:[/] seed {', '.join(missing)}")
        stale = [str(member.seed) for member in group.members if member.status == "stale" and member.report is not None]
        if stale:
            console.print(f"[yellow]stale:[/] seed {', '.join(stale)} (made by another build of the code or from other inputs; "
                          "launching the study again runs them again)")
        pages.append(ensemble_markdown(title, rows))
    if pages:
        (campaign_dir / ENSEMBLE_PAGE).write_text("\n".join(pages))
        console.print(f"ensemble: {campaign_dir / ENSEMBLE_PAGE} (every seed's numbers: {campaign_dir / 'ensemble.json'})")
    return failed


def launch_ensemble(kind_name: str, study_path: Path, name: str, engine: str | None, outdir: Path, jobs: int | None, executor: str,
                    dask_address: str | None, shared: Path | None) -> None:
    """Run a study file's seeds (`jobs` at once, default one per core), print each seed, the mean and
    the range; exit 3 when a seed failed (the others are reported), 2 on invalid input."""
    from orchestrator.engines import EngineError
    from orchestrator.campaign.ensemble import run_ensemble

    failures: list[str] = []
    with Progress(TextColumn("[bold]{task.fields[name]}[/]"), BarColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                  console=console, transient=True) as progress:
        task = progress.add_task("planning", total=None, name=name)

        def update(counts: Any, summary: dict[str, Any] | None) -> None:
            progress.update(task, total=counts.total, completed=counts.skipped + counts.done + counts.failed,
                            description=f"seeds: done {counts.done}  running {counts.running}  failed {counts.failed}  "
                                        f"remaining {counts.remaining}" + (f"  already there {counts.skipped}" if counts.skipped else ""))
            if summary and summary["status"] == "failed":
                failures.append(f"{summary['run_id']}: {summary.get('error', '')}")

        try:
            counts, _ = run_ensemble(kind_name, study_path, outdir, engine, jobs or os.cpu_count() or 1, executor, dask_address, shared,
                                     update, run_options())
        except CaseError as error:
            fail(str(error))
        except EngineError as error:
            fail(str(error), code=3)
    console.print(f"{outdir}: {counts.done} seed(s) run, {counts.skipped} already there, {counts.failed} failed")
    for line in failures:
        errors.print(f"[red]failed[/] {line}", markup=True, highlight=False)
    if report_ensembles(outdir, kind_name, name, always=True):
        sys.exit(3)
