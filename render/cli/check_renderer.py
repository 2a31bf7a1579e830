"""Command line of ``check-renderer``: parse options, build a CheckConfig, call run(cfg); exit 1
when the worst case is below the threshold."""

import json
from typing import Any

import click

from render.common.errors import InputError
from render.torch_renderer import gradient_check
from render.torch_renderer.check import DEFAULT_ROUGHNESS, CheckConfig, run


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--probes", required=True, type=click.Path(), help="Folder of HDR probes.")
@click.option("--svbrdfs", required=True, type=click.Path(), help="Folder of material folders.")
@click.option("--size", default=64, show_default=True, help="Image size (px).")
@click.option("--spp", default=1024, show_default=True, help="Mitsuba samples per pixel.")
@click.option("--roughness", default=",".join(map(str, DEFAULT_ROUGHNESS)), show_default=True,
              help="Comma-separated Ward alphas to cycle through.")
@click.option("--max-view-angle", default=0.0, show_default=True,
              help="Largest random view tilt from +z (degrees).")
@click.option("--seed", default=0, show_default=True)
@click.option("--threshold", default=40.0, show_default=True,
              help="Fail when any case's PSNR (dB) is below this.")
@click.option("--confirm-spp", default=0, show_default=True, type=click.IntRange(min=0),
              help="Render the cases below the threshold again at this many samples per pixel "
                   "and judge them against that reference (0: not).")
@click.option("--out", type=click.Path(), default=None,
              help="Write side-by-side images (Mitsuba | torch | 10x difference) and "
                   "report.json (with --gradients: gradients.json).")
@click.option("--gradients", is_flag=True,
              help="Compare gradients with Mitsuba's automatic differentiation instead of "
                   "images (--spp is then per pass).")
@click.option("--passes", default=8, show_default=True, type=click.IntRange(min=2),
              help="With --gradients: independent Mitsuba estimates per case.")
@click.option("--tolerance", default=0.02, show_default=True,
              help="With --gradients: fail where a relative L2 error exceeds this plus 3 "
                   "times the reference's relative noise.")
def main(roughness: str, **options: Any) -> None:
    """Compare the torch renderer with converged Mitsuba renders; exit 1 over the threshold.
    With --gradients, compare their gradients; exit 1 where they disagree."""
    try:
        values = tuple(float(v) for v in roughness.split(","))
    except ValueError:
        raise click.BadParameter(f"not a list of numbers: {roughness}", param_hint="--roughness")
    cfg = CheckConfig(roughness=values, **options)
    try:
        report = gradient_check.run(cfg) if cfg.gradients else run(cfg)
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None
    if cfg.gradients:
        _report_gradients(report)
        return
    for row in report["rows"]:
        click.echo(f"{row['psnr_db']:7.2f} dB  rel.MSE {row['relative_mse']:.2e}  "
                   f"alpha {row['roughness']:<5} {row['material']} / {row['probe']}")
    click.echo(json.dumps({k: v for k, v in report.items() if k != "rows"}, indent=2))
    if report["worst"]["psnr_db"] < cfg.threshold:
        raise click.ClickException(
            f"worst case {report['worst']['psnr_db']:.2f} dB is below {cfg.threshold} dB")


def _report_gradients(report: dict) -> None:
    """One line per case and parameter (relative L2 error, reference noise, cosine), the
    summary; exit 1 where a case disagrees."""
    for row in report["rows"]:
        cells = "  ".join(f"{name} {row[name]['error']:.4f}+-{row[name]['noise']:.4f} "
                          f"cos {row[name]['cosine']:.5f}" for name in gradient_check.PARAMETERS)
        click.echo(f"alpha {row['alpha']:<5} {row['material']} / {row['probe']}: {cells}")
    click.echo(json.dumps({k: v for k, v in report.items() if k != "rows"}, indent=2))
    summary = report["summary"]
    failed = [name for name in gradient_check.PARAMETERS if not summary[name]["all_agree"]]
    if failed:
        raise click.ClickException(f"gradients disagree beyond the tolerance plus 3x the "
                                   f"reference's noise: {', '.join(failed)}")


if __name__ == "__main__":
    main()
