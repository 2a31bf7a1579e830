"""``sa-validate``: the paper's validation of self-augmentation on BRDF-net.

Task: a monochrome image of a sphere of one homogeneous Ward BRDF under a monochrome probe ->
``(log(diffuse / specular), log(alpha))`` (train.brdf_validation.search_space). Spheres are
rendered with the torch renderer (``render.torch_renderer.renderer.sphere_normals``); probes
are reduced to their Rec. 709 luminance; each image is auto-exposed and clamped like the
dataset's, so only the ratio of the albedos is observable.

A *lighting* is a (probe, rotation) pair; ``lightings`` of them are drawn once per run. Each
labeled BRDF is seen under lightings drawn from that set; each unlabeled BRDF, and each test
BRDF, under one lighting of the set fixed for the run.
A run trains BRDF-net (train.networks.svbrdf_net.HomogeneousNet, 1 channel in, 2 out) on labeled
minibatches for ``labeled_iterations``; then, for ``augmented_iterations``, either labeled
minibatches alone (no self-augmentation) or pairs of a self-augmented minibatch (predict the
unlabeled spheres, clamp to the search space, render under a new lighting) and a labeled one.

Error, over the test set, each test BRDF under a lighting of its own: the MSE between the
exposed renders of the estimated and the true BRDF under that lighting (``render_mse``), and
the MSE of the two predicted values.

Resume: each finished run's result is kept in ``OUT/runs/`` and read back, not retrained, when
the same command is run again (a run's random stream depends on its name and the seed alone,
so a resumed validation equals an uninterrupted one); a killed run is redone whole. The output
path and the device may change between invocations (render.common.resume).
"""

import csv
import dataclasses
import json
import logging
import time
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure

from render.common.atomic_files import atomic_path, write_json
from render.common.color import luminance
from render.common.exposure import expose
from render.common.probes import find_probes, load_probe
from render.common.resume import continue_folder
from render.torch_renderer.renderer import ProbeBank, render, rotate_z, sphere_normals
from train.brdf_validation import search_space
from train.networks.svbrdf_net import HomogeneousNet, NetworkConfig
from train.training.self_augmentation import provisional_parameters
from train.training.optimization import OptimizerConfig, make_optimizer

log = logging.getLogger(__name__)
MAY_CHANGE = ("out", "device")
"""Options a resumed validation may change (render.common.resume)."""

ALPHA_LEVELS = np.geomspace(0.02, 1.0, 29)
"""Every training roughness (even levels) and test roughness (odd levels) of the search space."""
PATTERNS = ("5x5x7", "3x3x5", "2x2x2", "random-12.5", "random-3.7")
PAPER_MSE = {"dense": (0.0004, None), "5x5x7": (0.0010, 0.0004), "3x3x5": (0.0060, 0.0005),
             "2x2x2": (0.1001, 0.0005), "random-12.5": (0.0007, 0.0004),
             "random-3.7": (0.0029, 0.0004)}
"""The paper's total render MSE per labeled set: (without, with self-augmentation)."""
RATIO_LABELED = (5, 10, 20, 30, 50, 70, 80, 90, 95, 100)
RATIO_UNLABELED = (5, 10, 20, 30, 50, 70, 80, 90, 95)
"""The percentages of the paper's labeled-unlabeled ratio table."""


@dataclass(frozen=True)
class ValidationConfig:
    probes: str
    """Folder of HDR probes (reduced to luminance)."""
    out: str
    """Output folder: config.json, results.json, table.csv, table.md, heat_maps.png."""
    size: int = 128
    """Sphere image side (px); the authors' code uses 128."""
    lightings: int = 450
    """Fixed lightings the labeled BRDFs are seen under (the paper: 450)."""
    labeled_iterations: int = 20000
    """Minibatches of labeled data before the second phase."""
    augmented_iterations: int = 20000
    """Second phase: labeled minibatches, each after a self-augmented one when augmenting."""
    batch_size: int = 64
    width: int = 16
    """BRDF-net: channels of the first analysis block (doubling per level, up to 8x)."""
    levels: int = 5
    """BRDF-net: analysis blocks."""
    hidden: int = 1024
    """BRDF-net: hidden units of the fully connected synthesis."""
    alpha_levels: int = len(ALPHA_LEVELS)
    """Roughness levels of the sphere tables, log-uniform in [0.02, 1]; 29 holds the search
    space exactly, fewer interpolate it (the toy configuration)."""
    seed: int = 0
    device: str = "cpu"


CONFIGURATIONS = {
    "full": {},
    "small": {"size": 32, "lightings": 24, "labeled_iterations": 2000,
              "augmented_iterations": 2000, "batch_size": 32, "width": 8, "levels": 3,
              "hidden": 128},
    "toy": {"size": 16, "lightings": 4, "labeled_iterations": 5, "augmented_iterations": 5,
            "batch_size": 8, "width": 4, "levels": 2, "hidden": 16, "alpha_levels": 2},
}
"""``full``: the paper's sizes (for a GPU). ``small``: the same search space with smaller
images and network, fewer lightings and iterations, for a CPU. ``toy``: seconds, for tests."""


class SphereRenderer:
    """Auto-exposed monochrome sphere images (B, 1, S, S) of homogeneous BRDFs under a fixed
    set of lightings.

    A sphere's radiance is ``diffuse * D_k + specular * S_k(alpha)`` for lighting k, and all
    spheres share their normals, so D_k and S_k are rendered once with the torch renderer:
    S_k at ALPHA_LEVELS, which hold every training and test roughness of the search space
    exactly (other roughnesses, predicted ones, are interpolated linearly in log alpha). The
    toy configuration tabulates fewer levels and interpolates everything.
    """

    def __init__(self, probe_files: Sequence[str | Path], size: int, lightings: np.ndarray,
                 device: str, alpha_levels: np.ndarray | Sequence[float] | None = None):
        self.alpha_levels = ALPHA_LEVELS if alpha_levels is None else np.asarray(alpha_levels)
        self.log_levels = torch.as_tensor(np.log(self.alpha_levels), dtype=torch.float32)
        radiances = [load_probe(path).radiance for path in probe_files]
        gray = [np.repeat(luminance(r), 3).reshape(r.shape) for r in radiances]
        probes = ProbeBank(gray, device=device)
        normal, self.mask = sphere_normals(size, device=device)
        count = len(lightings)
        self.diffuse = torch.empty(count, 1, size, size, device=device)
        self.specular = torch.empty(len(self.alpha_levels), count, 1, size, size, device=device)
        # Seen from +z, a probe turned by r about +z lights a sphere as the unturned probe
        # lights the sphere turned by -r. So each probe is rendered once, with the turned
        # spheres of all its lightings side by side in one image: the renderer builds its
        # tables once per probe and level, not once per lighting.
        ones = torch.ones(1, 3, device=device)
        probe_of_lighting = lightings[:, 0].astype(int)
        for probe in np.unique(probe_of_lighting):
            members = np.flatnonzero(probe_of_lighting == probe)
            turned = turned_spheres(normal, -lightings[members, 1])
            strip = turned.permute(1, 2, 0, 3).reshape(1, 3, size, len(members) * size)
            index = [int(probe)]

            def spheres(image):  # (1, 3, S, m S) -> (m, 1, S, S), the members' spheres
                return image[0, :1].reshape(1, size, len(members), size).permute(2, 0, 1, 3)

            self.diffuse[members] = spheres(render(torch.ones_like(strip), strip, ones * 0,
                                                   ones[:, 0], probes, index))
            for level, alpha in enumerate(self.alpha_levels):
                self.specular[level, members] = spheres(render(
                    torch.zeros_like(strip), strip, ones, ones[:, 0] * float(alpha), probes,
                    index))

    def __call__(self, brdfs, lighting_index):
        """``brdfs`` (B, 3) diffuse, specular, alpha; ``lighting_index`` (B,) into the set."""
        brdfs = torch.as_tensor(brdfs, dtype=torch.float32, device=self.mask.device)
        k = torch.as_tensor(lighting_index, device=self.mask.device).long()
        log_alpha = torch.log(brdfs[:, 2]).clamp(float(self.log_levels[0]),
                                                 float(self.log_levels[-1]))
        lower = (torch.searchsorted(self.log_levels, log_alpha, right=True) - 1).clamp(
            0, len(self.log_levels) - 2)
        weight = ((log_alpha - self.log_levels[lower])
                  / (self.log_levels[lower + 1] - self.log_levels[lower]))[:, None, None, None]
        glossy = (1 - weight) * self.specular[lower, k] + weight * self.specular[lower + 1, k]
        hdr = brdfs[:, 0, None, None, None] * self.diffuse[k] + brdfs[:, 1, None, None, None] \
            * glossy
        return expose((hdr * self.mask).expand(-1, 3, -1, -1))[:, :1]


def turned_spheres(normal: torch.Tensor, angle_deg: np.ndarray | torch.Tensor) -> torch.Tensor:
    """Sphere normals (3, S, S) turned counter-clockwise about +z by each of ``angle_deg``
    (m,) degrees: (m, 3, S, S)."""
    angle = torch.as_tensor(angle_deg, dtype=normal.dtype, device=normal.device)
    size = normal.shape[-1]
    vectors = normal.reshape(3, -1).T.expand(len(angle), -1, -1)  # (m, S S, 3)
    return rotate_z(vectors, angle).transpose(1, 2).reshape(len(angle), 3, size, size)


def from_targets(values: np.ndarray) -> np.ndarray:
    """(N, 2) predicted log(d / s), log(alpha) -> (N, 3) BRDFs with d + s = 1, clamped to the
    search space's range of ratios and roughnesses."""
    ratio_limit = np.log(search_space.DIFFUSE[-1] / search_space.SPECULAR[0])
    ratio = np.exp(np.clip(values[:, 0], -ratio_limit, ratio_limit))
    alpha = np.exp(np.clip(values[:, 1], np.log(search_space.ROUGHNESS[0]), 0.0))
    return np.stack([ratio / (1 + ratio), 1 / (1 + ratio), alpha], -1)


def random_lightings(rng: np.random.Generator, count: int, probes: int) -> np.ndarray:
    """(count, 2) lightings: probe index, rotation in degrees."""
    return np.stack([rng.integers(probes, size=count), rng.uniform(0, 360, count)], -1)


def train_run(cfg: ValidationConfig, renderer: SphereRenderer, labeled_mask: np.ndarray,
              unlabeled_mask: np.ndarray, self_augment: bool,
              name: str) -> tuple[HomogeneousNet, list[tuple[str, float]]]:
    """Train one BRDF-net on the masked training BRDFs; ``name`` seeds its random stream.
    Returns (net, per-iteration losses)."""
    rng = np.random.default_rng([cfg.seed, zlib.crc32(name.encode()), int(self_augment)])
    torch.manual_seed(cfg.seed)
    brdfs = search_space.training_brdfs()
    labeled, unlabeled = brdfs[labeled_mask], brdfs[unlabeled_mask]
    unlabeled_lightings = np.random.default_rng([cfg.seed, 1]).integers(cfg.lightings,
                                                                        size=len(unlabeled))
    network = NetworkConfig(input_size=cfg.size, width=cfg.width, max_width=8 * cfg.width,
                            levels=cfg.levels, hidden=cfg.hidden)
    net = HomogeneousNet(network, in_channels=1, outputs=2).to(cfg.device)
    optimizer, scheduler = make_optimizer(net.parameters(), OptimizerConfig())
    losses = []
    kinds = ["labeled"] * cfg.labeled_iterations
    kinds += (["self-augmented", "labeled"] if self_augment and len(unlabeled) else
              ["labeled"]) * cfg.augmented_iterations
    for kind in kinds:
        if kind == "labeled":
            chosen = labeled[rng.integers(len(labeled), size=cfg.batch_size)]
        else:
            index = rng.integers(len(unlabeled), size=cfg.batch_size)
            with torch.no_grad():
                photos = renderer(unlabeled[index], unlabeled_lightings[index])
            chosen = from_targets(provisional_parameters(net, photos, batch_statistics=False)
                                  .cpu().numpy())
        images = renderer(chosen, rng.integers(cfg.lightings, size=cfg.batch_size))
        target = torch.as_tensor(search_space.targets(chosen), dtype=torch.float32,
                                 device=cfg.device)
        loss = torch.mean((net(images) - target) ** 2)
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        scheduler.step()
        losses.append((kind, loss.item()))
    return net, losses


def evaluate(cfg: ValidationConfig, renderer: SphereRenderer,
             net: HomogeneousNet) -> tuple[np.ndarray, np.ndarray]:
    """Per test BRDF: render MSE and parameter MSE, each (N,)."""
    tests = search_space.test_brdfs()
    lightings = np.random.default_rng([cfg.seed, 2]).integers(cfg.lightings, size=len(tests))
    render_errors, parameter_errors = [], []
    net.eval()
    with torch.no_grad():
        for start in range(0, len(tests), cfg.batch_size):
            part = slice(start, start + cfg.batch_size)
            images = renderer(tests[part], lightings[part])
            predicted = net(images).cpu().numpy()
            estimate = renderer(from_targets(predicted), lightings[part])
            render_errors.append(((estimate - images) ** 2).mean((1, 2, 3)).cpu().numpy())
            parameter_errors.append(((predicted - search_space.targets(tests[part])) ** 2).mean(1))
    return np.concatenate(render_errors), np.concatenate(parameter_errors)


def heat_map(errors: np.ndarray) -> np.ndarray:
    """(9, 14) mean error over diffuse x roughness, integrated (averaged) over specular."""
    return errors.reshape(9, 9, 14).mean(1)


def make_renderer(cfg: ValidationConfig) -> SphereRenderer:
    """The run's SphereRenderer: its lightings drawn from the seed."""
    probe_files = find_probes(cfg.probes)
    start = time.perf_counter()
    renderer = SphereRenderer(probe_files, cfg.size, random_lightings(
        np.random.default_rng(cfg.seed), cfg.lightings, len(probe_files)), cfg.device,
        np.geomspace(0.02, 1.0, cfg.alpha_levels))
    log.info("sphere tables for %d lightings in %.0f s", cfg.lightings,
             time.perf_counter() - start)
    return renderer


def ratio_table(cfg: ValidationConfig, renderer: SphereRenderer,
                labeled_percents: Sequence[float] = RATIO_LABELED,
                unlabeled_percents: Sequence[float] = RATIO_UNLABELED) -> dict[float, dict]:
    """The paper's labeled-unlabeled ratio table: test render MSE per labeled percentage,
    without self-augmentation and with each unlabeled percentage that fits beside it. Writes
    ratio_table.csv and ratio_table.md; returns {labeled: {"no SA" or unlabeled: MSE}}."""
    out = Path(cfg.out)
    table = {}
    for labeled_percent in labeled_percents:
        row = {}
        for unlabeled_percent in (0,) + tuple(u for u in unlabeled_percents
                                              if labeled_percent + u <= 100):
            labeled, unlabeled = search_space.random_split(labeled_percent, unlabeled_percent,
                                                         cfg.seed)
            name = f"ratio {labeled_percent} {unlabeled_percent}"
            mse = finished_run(out, name, lambda: _ratio_run(
                cfg, renderer, labeled, unlabeled, unlabeled_percent > 0, name))["render_mse"]
            row["no SA" if unlabeled_percent == 0 else unlabeled_percent] = mse
            log.info("ratio table: %s%% labeled, %s%% unlabeled: render MSE %.2e",
                     labeled_percent, unlabeled_percent, mse)
        table[labeled_percent] = row
    header = ["percent labeled", "no SA"] + [f"{u}% unlabeled" for u in unlabeled_percents]
    rows = [[str(p), *(f"{row[k]:.2e}" if k in row else "" for k in ["no SA",
                                                                      *unlabeled_percents])]
            for p, row in table.items()]
    with atomic_path(out / "ratio_table.csv") as tmp:
        with open(tmp, "w", newline="") as file:
            csv.writer(file).writerows([header, *rows])
    lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    with atomic_path(out / "ratio_table.md") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return table


def run(cfg: ValidationConfig,
        patterns: Sequence[str] = PATTERNS) -> tuple[dict[str, dict], SphereRenderer]:
    """Every run of the protocol; writes the table (CSV, Markdown), heat maps and JSON."""
    out = Path(cfg.out)
    for path in find_probes(cfg.probes):  # bad probes fail before the folder is claimed
        load_probe(path)
    continue_folder(out, dataclasses.asdict(cfg), MAY_CHANGE, "sa-validate")
    renderer = make_renderer(cfg)
    results = {}
    for pattern in ("dense",) + tuple(patterns):
        for self_augment in ((False,) if pattern == "dense" else (False, True)):
            key = f"{pattern}{' SA' if self_augment else ''}"
            results[key] = finished_run(out, key, lambda: _pattern_run(cfg, renderer, pattern,
                                                                       self_augment))
            log.info("%s: render MSE %.5f, parameter MSE %.4f (%.0f s)", key,
                     results[key]["render_mse"], results[key]["parameter_mse"],
                     results[key]["seconds"])
    write_json(out / "results.json", results)
    _write_tables(out, results)
    _plot_heat_maps(out / "heat_maps.png", results, cfg.seed)
    return results, renderer


def _ratio_run(cfg, renderer, labeled, unlabeled, self_augment, name):
    """Train and evaluate one run of the ratio table; its result dict."""
    net, _ = train_run(cfg, renderer, labeled, unlabeled, self_augment, name)
    return {"render_mse": float(evaluate(cfg, renderer, net)[0].mean())}


def _pattern_run(cfg, renderer, pattern, self_augment):
    """Train and evaluate the run of one labeled set; its result dict."""
    start = time.perf_counter()
    mask = search_space.labeled_mask(pattern, cfg.seed)
    net, _ = train_run(cfg, renderer, mask, ~mask, self_augment, pattern)
    render_errors, parameter_errors = evaluate(cfg, renderer, net)
    return {"pattern": pattern, "self_augmented": self_augment, "labeled": int(mask.sum()),
            "render_mse": float(render_errors.mean()),
            "parameter_mse": float(parameter_errors.mean()),
            "heat_map": heat_map(render_errors).tolist(),
            "seconds": round(time.perf_counter() - start, 1)}


def finished_run(out: Path, name: str, compute: Callable[[], dict]) -> dict:
    """The result dict of run ``name``: read from ``out/runs/`` when an earlier invocation
    finished it, else ``compute()``d and written there (atomically) first."""
    path = out / "runs" / f"{name.replace(' ', '_')}.json"
    if path.is_file():
        log.info("%s: finished earlier, read from %s", name, path)
        return json.loads(path.read_text())
    result = compute()
    write_json(path, result)
    return result


def _patterns(results):
    """The labeled sets of ``results``: dense first, then in PATTERNS order, then others."""
    order = ("dense",) + PATTERNS
    present = dict.fromkeys(r["pattern"] for r in results.values())
    return sorted(present, key=lambda p: order.index(p) if p in order else len(order))


def _write_tables(out, results):
    rows = []
    for pattern in _patterns(results):
        without = results[pattern]
        with_sa = results.get(f"{pattern} SA")
        paper = PAPER_MSE.get(pattern, (None, None))
        rows.append({"labeled set": pattern, "labeled BRDFs": without["labeled"],
                     "render MSE": f"{without['render_mse']:.2e}",
                     "render MSE with SA": f"{with_sa['render_mse']:.2e}" if with_sa else "",
                     "paper": "" if paper[0] is None else f"{paper[0]:.4f}",
                     "paper with SA": "" if paper[1] is None else f"{paper[1]:.4f}"})
    with atomic_path(out / "table.csv") as tmp:
        with open(tmp, "w", newline="") as file:
            writer = csv.DictWriter(file, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    lines = ["| " + " | ".join(rows[0]) + " |", "|" + " --- |" * len(rows[0])]
    lines += ["| " + " | ".join(str(v) for v in row.values()) + " |" for row in rows]
    with atomic_path(out / "table.md") as tmp:
        tmp.write_text("\n".join(lines) + "\n")


def _plot_heat_maps(path, results, seed):
    """One column per labeled set: its sampling pattern (labeled count over specular, per
    diffuse x roughness), the error heat map without and with SA (one log color scale)."""
    patterns = _patterns(results)
    figure = Figure(figsize=(2.8 * len(patterns), 9), layout="constrained")
    axes = figure.subplots(3, len(patterns), squeeze=False)
    maps = [np.asarray(r["heat_map"]) for r in results.values()]
    scale = LogNorm(vmin=min(m[m > 0].min() for m in maps), vmax=max(m.max() for m in maps))
    for column, pattern in enumerate(patterns):
        mask = search_space.labeled_mask(pattern, seed).reshape(10, 10, 15).sum(1)
        axes[0, column].imshow(mask, cmap="Greys", origin="lower", aspect="auto", vmin=0,
                               vmax=len(search_space.SPECULAR))
        axes[0, column].set_title(f"{pattern}: labeled", fontsize=9)
        for row, key in ((1, pattern), (2, f"{pattern} SA")):
            axis = axes[row, column]
            if key in results:
                image = axis.imshow(np.asarray(results[key]["heat_map"]), cmap="inferno",
                                    origin="lower", aspect="auto", norm=scale)
                axis.set_title(f"{'SA' if row == 2 else 'no SA'}: "
                               f"{results[key]['render_mse']:.1e}", fontsize=9)
            else:
                axis.axis("off")
    for axis in axes.ravel():
        axis.set_xlabel("roughness index", fontsize=7)
        axis.set_ylabel("diffuse index", fontsize=7)
        axis.tick_params(labelsize=6)
    figure.colorbar(image, ax=axes[1:].ravel().tolist(),
                    label="render MSE (mean over specular), log scale")
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format="png", dpi=100)
