"""The figures a GPU user needs, in one call: started once on a machine with a CUDA GPU, runs
the project's benchmarks and ``sa-validate --config full`` there and writes JSON and a short
Markdown table (docs/performance.md and docs/brdf-validation.md take them).

    python benchmarks/gpu_figures.py --out OUT [--budget 500] [--seeds 10] [--device cuda] \
        [--toy]

Steps, each a child process (its own benchmark's JSON kept as ``OUT/<step>.json``, so a re-run
skips the finished steps and a cut-off call continues in the next):

- ``mitsuba_llvm``, ``mitsuba_cuda``: benchmarks/render_throughput.py, seconds per 256 px
  ground-truth image at 256 spp (the 50 dB floor of docs/performance.md; its PSNR against 16x
  the samples), with Mitsuba ``llvm_ad_rgb`` and ``cuda_ad_rgb`` on the same cases, and the
  PSNR of the cuda renders against the llvm ones;
- ``torch_b16_mix``, ``torch_b16_a0.02``, ``torch_b64_mix``, ``torch_b64_a0.02``:
  benchmarks/torch_renderer_throughput.py, images per second at 256 px, batch 16 and 64, the
  random roughness mix and alpha 0.02;
- ``train_compact``, ``train_paper``: benchmarks/minibatch_cost.py, one sa-train step of the
  compact and paper networks with labeled maps and with self-augmentation (batch 16);
- ``estimate_1024``: ``sa-estimate`` of the bundled photo enlarged to 1024 x 768 px (the
  network and full-resolution milliseconds it reports, and the command's wall time);
- ``validate_seed<N>``: ``sa-validate --config full --patterns 2x2x2`` (the dense baseline and
  2x2x2 with and without self-augmentation) for seeds 0, 1, ... up to ``--seeds`` while the
  budget lasts; a seed cut off continues in the next call (sa-validate resumes its folder,
  OUT/validate/).

``--budget`` (seconds) bounds the whole call: each step gets what is left (a step cut off is
not kept and runs again next time). ``--toy`` runs every step at toy size (tiny images, few
samples, the ``toy`` validation, ``llvm_ad_rgb`` twice): what tests/test_gpu_figures.py runs on
the CPU.
"""

import json
import platform
import subprocess
import sys
import time
from pathlib import Path

import click
from PIL import Image

from render.common.atomic_files import atomic_path, write_json

REPO = Path(__file__).resolve().parent.parent
BENCHMARKS = REPO / "benchmarks"
PHOTO = REPO / "scenes" / "photos" / "brick-reference-01.jpg"


def steps(out: Path, device: str, toy: bool) -> dict[str, list[str]]:
    """{step name: argv} of the fixed steps, in order."""
    python = [sys.executable]
    size = ["--size", "32"] if toy else ["--size", "256"]
    mitsuba = [*python, str(BENCHMARKS / "render_throughput.py"), *size, "--spp",
               "4" if toy else "256", "--pairs", "2" if toy else "8"]
    gpu_variant = "llvm_ad_rgb" if toy else "cuda_ad_rgb"
    found = {
        "mitsuba_llvm": [*mitsuba, "--variant", "llvm_ad_rgb", "--no-reference", "--save",
                         str(out / "renders-llvm.npz")],
        "mitsuba_cuda": [*mitsuba, "--variant", gpu_variant, "--compare-to",
                         str(out / "renders-llvm.npz")],
    }
    for batch in (16, 64):
        for roughness in ("mix", "0.02"):
            found[f"torch_b{batch}_{'a' if roughness != 'mix' else ''}{roughness}"] = [
                *python, str(BENCHMARKS / "torch_renderer_throughput.py"), *size, "--batch",
                str(2 if toy else batch), "--device", device, "--compare", "0",
                "--repeats", "1" if toy else "5",
                *([] if roughness == "mix" else ["--roughness", roughness])]
    for network in ("compact", "paper"):
        found[f"train_{network}"] = [
            *python, str(BENCHMARKS / "minibatch_cost.py"), "--network",
            "small" if toy else network, "--batch", "2" if toy else "16", "--repeats",
            "1" if toy else "5", "--device", device]
    found["estimate_1024"] = [
        *python, "-m", "train.cli.sa_estimate", str(out / "photo-1024.jpg"), "--out",
        str(out / "estimate-1024"), "--overwrite", "--device", device,
        *(["--max-side", "64"] if toy else [])]
    return found


def validate_step(out: Path, device: str, toy: bool, seed: int) -> list[str]:
    return [sys.executable, "-m", "train.cli.sa_validate", "--probes", str(REPO / "probes"),
            "--out", str(out / "validate" / f"seed{seed}"), "--config",
            "toy" if toy else "full", "--patterns", "2x2x2", "--seed", str(seed),
            "--device", device]


def run_step(argv: list[str], seconds: float) -> tuple[dict | None, float]:
    """(the step's result, or None if it was cut off or failed, with why on stderr; its wall
    seconds). A benchmark's result is its JSON; sa-estimate's the last JSON line;
    sa-validate's its results.json."""
    start = time.perf_counter()
    try:
        done = subprocess.run(argv, cwd=REPO, capture_output=True, text=True,
                              timeout=max(seconds, 1.0))
    except subprocess.TimeoutExpired:
        print(f"cut off after {seconds:.0f} s: {' '.join(argv[:3])}", file=sys.stderr)
        return None, time.perf_counter() - start
    wall = time.perf_counter() - start
    if done.returncode != 0:
        print(f"failed: {' '.join(argv[:3])}: {done.stderr.strip()[-2000:]}", file=sys.stderr)
        return None, wall
    if "train.cli.sa_validate" in argv:
        folder = Path(argv[argv.index("--out") + 1])
        return json.loads((folder / "results.json").read_text()), wall
    lines = [line for line in done.stdout.splitlines() if line.strip()]
    if "train.cli.sa_estimate" in argv:
        return json.loads(lines[-1]), wall
    return json.loads(done.stdout), wall


def markdown(figures: dict) -> str:
    """The short table of the figures found."""
    rows = ["| figure | value |", "| --- | --- |"]

    def row(name, text):
        rows.append(f"| {name} | {text} |")

    for variant in ("llvm", "cuda"):
        result = figures.get(f"mitsuba_{variant}")
        if result:
            text = f"{1 / result['images_per_second']:.3f} s per image"
            if "min_psnr_db_vs_16x" in result:
                text += f", worst {result['min_psnr_db_vs_16x']:.1f} dB against 16x the samples"
            if "min_psnr_db_vs_compared" in result:
                text += f", worst {result['min_psnr_db_vs_compared']:.1f} dB against llvm_ad_rgb"
            row(f"Mitsuba {result['variant']}, {result['size']} px, {result['spp']} spp", text)
    for name, result in figures.items():
        if name.startswith("torch_") and result:
            row(f"torch renderer, batch {result['batch']}, {result['size']} px, roughness "
                f"{result['roughness']}", f"{result['torch_images_per_second']} images/s")
        if name.startswith("train_") and result:
            row(f"sa-train step, {result['network']} network, batch {result['batch']}",
                f"{result['labeled_step_ms']} ms labeled, {result['self_augmented_step_ms']} ms "
                f"self-augmented")
        if name.startswith("validate_seed") and result:
            dense = result["dense"]["render_mse"]
            without = result["2x2x2"]["render_mse"]
            with_sa = result["2x2x2 SA"]["render_mse"]
            row(f"sa-validate 2x2x2, {name[len('validate_'):]}",
                f"render MSE dense {dense:.2e}, 2x2x2 {without:.2e}, with SA {with_sa:.2e} "
                f"(drop {without / with_sa:.1f}x; {with_sa / dense:.2f}x dense)")
    result = figures.get("estimate_1024")
    if result:
        row(f"sa-estimate, a {result['map_size'][0]} x {result['map_size'][1]} photo",
            f"{result['network_ms']} ms network, {result['full_resolution_ms']} ms full "
            f"resolution, {result['wall_seconds']:.1f} s for the command")
    return "\n".join(rows) + "\n"


@click.command()
@click.option("--out", required=True, type=click.Path(file_okay=False), help="Output folder.")
@click.option("--budget", default=500.0, show_default=True, help="Seconds for the whole call.")
@click.option("--device", default="cuda", show_default=True, help="torch device.")
@click.option("--seeds", default=10, show_default=True, help="Most validation seeds.")
@click.option("--toy", is_flag=True, help="Every step at toy size (for the CPU test).")
def main(out, budget, seeds, device, toy):
    started = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with Image.open(PHOTO) as photo:
        with atomic_path(out / "photo-1024.jpg") as tmp:
            photo.convert("RGB").resize((1024, 768), Image.Resampling.BICUBIC).save(
                tmp, "JPEG", quality=95)
    figures = {}
    planned = list(steps(out, device, toy).items())
    planned += [(f"validate_seed{seed}", validate_step(out, device, toy, seed))
                for seed in range(seeds)]
    for name, argv in planned:
        path = out / f"{name}.json"
        if path.is_file():
            figures[name] = json.loads(path.read_text())
            continue
        left = budget - (time.perf_counter() - started)
        if left <= 1.0:
            continue  # the steps left are for the next call
        result, wall = run_step(argv, left)
        if result is None:
            continue
        if name == "estimate_1024":
            result["wall_seconds"] = round(wall, 2)
        write_json(path, result)
        figures[name] = result
        print(f"{name}: {wall:.1f} s", file=sys.stderr, flush=True)
    machine = {"processor": platform.machine(), "device": device, "toy": toy}
    if device.startswith("cuda"):
        import torch
        machine["gpu"] = torch.cuda.get_device_name(0)
    write_json(out / "gpu_figures.json", {"machine": machine, "figures": figures})
    with atomic_path(out / "gpu_figures.md") as tmp:
        tmp.write_text(f"Machine: {machine}\n\n" + markdown(figures))
    print((out / "gpu_figures.md").read_text())


if __name__ == "__main__":
    main()
