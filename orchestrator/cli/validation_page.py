"""`demorch validation`: record the validation runs and write the validation page from the record."""

from __future__ import annotations

import json
import stat
import tempfile
from pathlib import Path
from typing import Any

import click

from orchestrator.cli.common import EXIT_DAMAGED, EXIT_ENGINE, REPO_ROOT, console, fail
from orchestrator.engines import ENGINE_NAMES, EngineError, engines_with, get_adapter

DEFAULT_RECORD = REPO_ROOT / "docs" / "validation" / "record.json"
DEFAULT_PAGE = REPO_ROOT / "docs" / "validation.md"


@click.command("validation")
@click.option("--engine", "-e", "engines", type=click.Choice(ENGINE_NAMES), multiple=True,
              help="Engines to measure (repeatable; default: every installed engine that runs clumps).")
@click.option("--demo", is_flag=True, help="Also run the demo avalanche with three seeds per engine (2–6 minutes each).")
@click.option("--page-only", is_flag=True, help="Run nothing: write the page from the existing record.")
@click.option("--record", "record_path", type=click.Path(dir_okay=False, path_type=Path), default=DEFAULT_RECORD, show_default=True,
              help="The record of measurements (JSON).")
@click.option("--page", type=click.Path(dir_okay=False, path_type=Path), default=DEFAULT_PAGE, show_default=True,
              help="The Markdown page; its figures go into a folder named like the record's.")
@click.option("--workdir", type=click.Path(file_okay=False, path_type=Path), help="Keep the runs here (default: a temporary directory).")
def validation(engines: tuple[str, ...], demo: bool, page_only: bool, record_path: Path, page: Path, workdir: Path | None) -> None:
    """Run the single-brick drops of the 2012 study (about a minute per engine; with --demo, the demo
    avalanche too) against their references, record the measurements, and write the validation page."""
    from orchestrator.studies import validation_page as pages

    if page_only:
        try:
            record = read_validation_record(record_path)
        except (OSError, ValueError) as error:
            fail(f"--record: cannot read {record_path} ({error})")
    else:
        wanted = engines or engines_with(clumps=True)
        able = engines_with(clumps=True)
        unable = [name for name in wanted if name not in able]
        if unable:
            fail(f"--engine: {', '.join(unable)} cannot run the drops (a brick is a clump); engines that can: {', '.join(able)}")
        versions = {name: get_adapter(name).info() for name in wanted}
        missing = [name for name, info in versions.items() if not info.executable]
        if missing:
            fail(f"--engine: {', '.join(missing)} not installed (`demorch doctor` says what is missing)")
        try:
            with tempfile.TemporaryDirectory(prefix="demorch-validation-") as scratch:
                record = pages.record_runs({name: info.version or "" for name, info in versions.items()}, workdir or Path(scratch),
                                           demo=demo, progress=lambda stage: console.print(stage))
        except EngineError as error:
            fail(str(error), code=EXIT_ENGINE)
        if record_path.exists():  # engines not run again keep their rows; the collapse row is recorded apart (demorch collapse record)
            try:
                record = pages.merge_records(read_validation_record(record_path), record)
            except (OSError, ValueError) as error:  # keep what was just measured beside the damaged record
                kept = record_path.with_name(record_path.stem + ".new.json")
                kept.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
                fail(f"--record: cannot read {record_path} to add to it ({error}); this run's record is in {kept}", code=EXIT_DAMAGED)
        record_path.parent.mkdir(parents=True, exist_ok=True)
        record_path.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
        console.print(f"record: {record_path}")
    figures = record_path.parent
    page.write_text(pages.render_page(record, figures, figures_link=str(figures.relative_to(page.parent.resolve()) if figures.is_relative_to(page.parent.resolve()) else figures)))
    console.print(f"page: {page}")


MAX_RECORD_BYTES = 50_000_000  # a validation record is about 1 MB (its curves); anything far larger is not one


def read_validation_record(path: Path) -> dict[str, Any]:
    """The validation record at `path`: a regular JSON file of at most MAX_RECORD_BYTES holding an
    object with `versions` and `drops` mappings. ValueError (one line) otherwise, before reading a
    device, a FIFO or an endless file; OSError when it cannot be opened."""
    if not stat.S_ISREG(path.stat().st_mode):
        raise ValueError("not a regular file")
    size = path.stat().st_size
    if size > MAX_RECORD_BYTES:
        raise ValueError(f"{size / 1e6:.0f} MB; a validation record is at most {MAX_RECORD_BYTES / 1e6:.0f} MB")
    record = json.loads(path.read_text())
    if not isinstance(record, dict) or not all(isinstance(record.get(key), dict) for key in ("versions", "drops")):
        raise ValueError("not a validation record: it has no `versions` and `drops` mappings (`demorch validation` writes one)")
    return record
