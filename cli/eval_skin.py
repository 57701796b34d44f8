"""`rigforge eval skin DIR [--method M ...] [--peers DIR] [--json FILE]`: skin-only evaluation on the assets' own skeletons.

Registered in cli/main.py as `eval_app.command("skin")(eval_skin.eval_skin)`. Peer weights (Blender's) come
from `bench/peers/blender_weights.py`, which writes bench/results/peers/blender/<asset>.npz; that folder's
parent is the default --peers.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.table import Table

from cli.eval_output import print_table_and_problems, write_report_json

PRIOR_SHARE_HELP = ("the geodesic prior's share in the learned weights (default: the shipped one, "
                    "simcore/skinning/learned.py PRIOR_SHARE; 0: the model alone)")

if TYPE_CHECKING:  # the evaluation imports torch: loaded when the command runs, not with every `rigforge` call
    from simcore.evaluation.skin_eval import SkinEvaluation, SkinRow

DEFAULT_PEERS = Path("bench/results/peers")


def _fmt(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


METRIC_HEADS = ("L1", "prec", "recall", "def", "def p95", "clip", "clip p95", "s")


def metric_cells(metrics: dict) -> list[str]:
    """One row's METRIC_HEADS cells ("-" where a metric is missing)."""
    return [
        _fmt(metrics.get("l1"), 3),
        _fmt(metrics.get("precision"), 2),
        _fmt(metrics.get("recall"), 2),
        _fmt(metrics.get("deform_mean"), 4),
        _fmt(metrics.get("deform_p95"), 4),
        _fmt(metrics.get("clip_deform_mean"), 4),
        _fmt(metrics.get("clip_deform_p95"), 4),
        _fmt(metrics.get("seconds"), 2),
    ]


def _peer_mark(row: SkinRow) -> str:
    """" (failed 100%)" / " (partial 12%)" after a peer's method name: its solve status, vertices unweighted."""
    if row.status in (None, "ok") or row.error:
        return ""
    return f" ({row.status} {row.unweighted_share or 0:.0%})"


def render(report: SkinEvaluation, console: Console) -> None:
    """Each asset's methods on consecutive rows (ours beside Blender's), then per-method means (all, then per category)."""
    table = Table(title="Skin-only on the assets' own skeletons; deformation in unit-cube units (random poses | own clips)")
    for head in ("asset", "category", "method"):
        table.add_column(head)
    for head in METRIC_HEADS:
        table.add_column(head, justify="right")
    names = list(dict.fromkeys(r.name for r in report.rows))
    for name in names:
        rows = [r for r in report.rows if r.name == name]
        for i, r in enumerate(rows):
            first = i == 0
            label = r.method + (f" → {r.chosen}" if r.chosen else "") + _peer_mark(r)
            cells = ["error"] + [""] * 7 if r.error else metric_cells(r.metrics)
            table.add_row(name if first else "", r.category if first else "", label, *cells, end_section=i == len(rows) - 1)
    categories = sorted({r.category for r in report.rows})
    subsets = [("MEAN (all)", None)] + [(f"MEAN ({c})", {r.name for r in report.rows if r.category == c}) for c in categories]
    for title, subset in subsets:
        for i, m in enumerate(report.methods()):
            table.add_row(title if i == 0 else "", "", m, *metric_cells(report.mean(m, subset)), style="bold",
                          end_section=i == len(report.methods()) - 1)
    for peer, means in report.peer_means().items():  # peers with and without failed/partial solves, ours on the same assets
        scored = means["ok"] + means["partial"] + means["failed"]
        for title, key, count in ((f"MEAN ({peer} scored: {means['failed']} failed, {means['partial']} partial)", "scored", scored),
                                  (f"MEAN ({peer} solved)", "solved", means["ok"])):
            for i, m in enumerate(report.methods()):
                table.add_row(title if i == 0 else "", f"{count} assets" if i == 0 else "", m, *metric_cells(means[key][m]),
                              style="bold", end_section=i == len(report.methods()) - 1)
    print_table_and_problems(console, table, report.skipped, (f"{r.name} {r.method}: {r.error}" for r in report.rows if r.error))


def eval_skin(
    directory: Annotated[Path, typer.Argument(exists=True, file_okay=False, help="folder of rigged .glb/.gltf (MANIFEST.tsv optional)")],
    method: Annotated[list[str] | None, typer.Option(help="auto, learned, geodesic, heat, or all (every method but auto); "
                                                           "repeat it for several (default: auto)")] = None,
    peers: Annotated[Path, typer.Option(help="folder of peer weights: PEERS/<peer>/<asset>.npz")] = DEFAULT_PEERS,
    json_path: Annotated[Path | None, typer.Option("--json", help="write the JSON report here")] = None,
    pipeline: Annotated[bool, typer.Option(help="add full-pipeline rows: our skeleton + our weights vs the artist's rig")] = False,
    split: Annotated[str | None, typer.Option(help="only the files DIR/MANIFEST.tsv lists for this split (train, val)")] = None,
    model: Annotated[Path | None, typer.Option(exists=True, dir_okay=False,
                                               help="learned skinning weights (.safetensors) to score instead of the shipped ones, "
                                                    "e.g. a fresh `rigforge train skin` output")] = None,
    prior_share: Annotated[float | None, typer.Option(min=0.0, max=1.0, help=PRIOR_SHARE_HELP)] = None,
) -> None:
    """Re-skin every rigged asset on its own skeleton and compare with the artist's weights (and peers)."""
    from simcore.evaluation.skin_eval import evaluate_skinning
    from simcore.skinning.learned import SHIPPED

    console = Console() if Console().is_terminal else Console(width=150)  # files and pipes get the full table
    with console.status("skinning…") as status:
        report = evaluate_skinning(directory, method or ["auto"], peers=peers, pipeline=pipeline, split=split,
                                   learned=SHIPPED.overridden(model, prior_share),
                                   on_asset=lambda n: status.update(f"skinning {n}"))
    render(report, console)
    write_report_json(console, json_path, report.to_dict())


if __name__ == "__main__":
    typer.run(eval_skin)
