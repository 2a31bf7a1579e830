"""The training loop of ``sa-train``: SVBRDF-net with or without self-augmentation.

``run(cfg)`` trains on a ``render-dataset`` output, following train.training.schedule: labeled
epochs, then epochs that interleave self-augmented minibatches (train.training.self_augmentation)
with labeled ones; without ``unlabeled`` data the same schedule runs on labeled minibatches alone
(the baseline). Into ``out`` it writes:

    config.json            the resolved configuration; a re-run continues only with the same
                           options, except MAY_CHANGE (render.common.resume)
    checkpoints/           step-000001000.pt ... (train.networks.checkpoints); a run resumes from
                           the newest and continues exactly as if it had not stopped
    tensorboard/           scalars (losses, learning rate, test errors) and example images
    history.json           every logged loss and every evaluation, also in the checkpoints
    loss_curves.png        training losses and test errors over the steps
    examples.png           the newest evaluation's examples (input, albedo, normals)

It logs a line every ``log_every`` steps and at every checkpoint (losses, ms per step, time
left) and evaluates on the test split (train.training.test_evaluation) at the end of every epoch.

Under ``torchrun`` the processes train one network data-parallel (train.training.distributed): each
takes its shard of every global minibatch of ``batch_size``, and only rank 0 writes and
evaluates.
"""

import dataclasses
import json
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from matplotlib.figure import Figure
from PIL import Image
from torch.utils.tensorboard import SummaryWriter

from render.common.atomic_files import atomic_path, write_json
from render.common.errors import InputError
from render.common.probes import find_probes, load_probe, tilted
from render.common.resume import continue_folder
from render.torch_renderer.renderer import ProbeBank
from train.data.labeled_dataset import LabeledDataset
from train.data.map_samples import MapSampler
from train.data.unlabeled_data import UnlabeledImages
from train.data.unlabeled_selection import select_matching
from train.networks.checkpoints import (
    checkpoint_files,
    load_checkpoint,
    newest_step,
    save_checkpoint,
)
from train.networks.model_files import load_network
from train.networks.svbrdf_net import PARTS, NetworkConfig, SVBRDFNet
from train.training import distributed
from train.training.interruption import StopRequest, TrainingStopped
from train.training.losses import ALBEDO_LOSSES, RELIT_LOSS_FORMS, losses, relit_loss
from train.training.optimization import OptimizerConfig, make_optimizer
from train.training.schedule import SELF_AUGMENTED, Schedule, labeled_batch_indices
from train.training.self_augmentation import random_lightings, self_augmented_batch
from train.training.test_evaluation import evaluate, stack_items

log = logging.getLogger(__name__)
RELIT_LOSS_STREAM = 1
"""Third seed word of the random stream of step ``index``'s relit-loss lightings:
(seed, index, RELIT_LOSS_STREAM)."""
RELIT_NETWORKS = ("homogeneous", "albedo")
"""The networks the relit loss trains. The normal network learns from its own loss alone: under
a relit loss weighted as the specular lobe needs (300), it learned normals that relight, not
the relief (tilted nearly to grazing on metal;
docs/experiments/2026-12-06-relit-loss-networks.md)."""
RELIT_PARTNERS = ("truth", "estimate")
"""What the relit loss renders for untrained networks' labels (TrainConfig.relit_partners)."""
LABELED_COLORS_STREAM = 2 ** 32 - 1
"""Second seed word of the random stream of the labeled samples whose colors choose the
unlabeled subset; step ``index`` uses (seed, index), and no run reaches this many steps."""
PROBE_TILTS_STREAM = 2 ** 32 - 2
"""Second seed word of the random stream of the tilted probe copies (TrainConfig.probe_tilts)."""
FRESH_WHEN_CHANGED = {"homogeneous_pooling": "homogeneous", "albedo_network": "albedo"}
"""Network configuration fields in which an ``init_from`` model may differ from the run, and
the network each shapes (which then starts fresh)."""
MAY_CHANGE = ("out", "device", "log_every", "checkpoint_every")
"""Options that do not change the trained weights: a resumed run may use other values
(render.common.resume), so a moved run folder, or a CPU run continued on a GPU, resumes.
``labeled_epochs`` may change too while the run's steps all lie in the labeled phase
(labeled_phase_holds): a short run continues into a longer one."""


@dataclass(frozen=True)
class TrainConfig:
    out: str
    """Run folder (see the module docstring)."""
    probes: str
    """Folder of HDR probes for the relit evaluation, the self-augmentation renders and the
    ``labeled_maps`` renders (these use only the probes of the dataset's train split, when a
    dataset is given and the folder holds them)."""
    dataset: str | None = None
    """A render-dataset output folder: its train split trains (unless ``labeled_maps`` is
    given), its test split evaluates."""
    labeled_maps: str | None = None
    """A folder of material folders: labeled minibatches are rendered from them on the fly by
    the torch renderer (train.data.map_samples) instead of read from ``dataset``."""
    init_from: str | None = None
    """A model (shipped file, checkpoint or run folder) whose weights start the training, for
    fine-tuning; its network configuration must equal ``network`` but for the fields of
    FRESH_WHEN_CHANGED (Run._initialize_from). None: random weights."""
    train_networks: tuple = tuple(PARTS)
    """The networks trained (names of train.networks.svbrdf_net.PARTS). The others keep their
    weights (from ``init_from``), stay in evaluation mode and are not run in labeled steps: the
    paper trains its three networks separately, and training the homogeneous network alone costs
    about a third of a whole step."""
    render_size: int = 512
    """With ``labeled_maps``: the shorter side the material maps are resampled to before
    cropping (render-dataset's ``--render-size``)."""
    crop_scales: tuple = (1,)
    """With ``labeled_maps``: each crop spans the input size times one of these whole numbers
    of map pixels, box filtered to the input size (train.data.map_samples): (1, 2) shows textures
    at their scale and at half of it. ``render_size`` must hold the largest crop."""
    mix_specular: bool = False
    """With ``labeled_maps``: each sample takes the specular albedo and roughness of a random
    material of the folder, not only its own (train.data.map_samples: with one pair per material,
    the network learns which texture has which pair instead of reading the reflection)."""
    epoch_samples: int = 3200
    """With ``labeled_maps``: labeled samples per epoch."""
    unlabeled: str | None = None
    """Folder of unlabeled photos, or a dataset folder whose labels are ignored; None: baseline."""
    network: NetworkConfig = field(default_factory=NetworkConfig)
    optimizer: OptimizerConfig = field(default_factory=OptimizerConfig)
    batch_size: int = 16
    """Samples per minibatch (the global minibatch, split among the processes under torchrun)."""
    labeled_epochs: int = 10
    """Epochs of labeled minibatches only (the paper: 10)."""
    self_augmented_epochs: int = 10
    """Epochs interleaving self-augmented and labeled minibatches (the paper: 10)."""
    unlabeled_per_labeled: float = 1.0
    """Self-augmented minibatches per labeled one in those epochs (the paper: 1; a fraction
    such as 0.5 puts one before every other labeled minibatch, train/training/schedule.py)."""
    unlabeled_limit: int | None = None
    """Most unlabeled images in the color-matched subset."""
    albedo_loss: str = "linear"
    """The albedo network's loss: "linear" (the paper's squared error of the relative albedo)
    or "log" (of its logarithm, train.training.losses.losses)."""
    relit_loss_weight: float = 0.0
    """Weight of the relit loss (train.training.losses.relit_loss) added to every step's loss: the
    estimate and the truth rendered under a new random probe (of those labeled renders use)
    and rotation, as the evaluation's relit error compares them. 0: the parameter losses
    alone, as the paper trains."""
    relit_loss_size: int = 64
    """Side (px) the maps are box filtered to for the relit loss's renders."""
    relit_loss_form: str = "log"
    """How the relit loss compares the renders (train.training.losses.RELIT_LOSS_FORMS): "log", the
    mean squared difference of log(1 + x); "rmse", the evaluation's relit error (clamped
    renders, a root per sample)."""
    relit_partners: str = "truth"
    """What the relit loss renders for the labels of the networks not trained (RELIT_PARTNERS):
    "truth", the labels themselves; or "estimate", the frozen networks' own estimates, so that
    a network learns the parameters that relight best beside the other networks' errors, as
    the estimates are used together."""
    max_view_angle: float = 0.0
    """Largest view tilt (degrees) of the self-augmentation renders."""
    probe_tilts: int = 0
    """Tilted copies of each probe that labeled renders, the relit loss and self-augmentation
    render under (render.common.probes.tilted), added to the probes themselves: the probe's
    zenith moved to a direction drawn uniformly over the cap within ``max_probe_tilt`` of +z.
    A flat sample under an overhead camera mirrors its probe's zenith, and few real probes
    have their brightest light there: a tilted copy brings a low sun or a lamp overhead."""
    max_probe_tilt: float = 60.0
    """Largest tilt (degrees) of the copies of ``probe_tilts``."""
    seed: int = 0
    checkpoint_every: int = 500
    """Optimizer steps between checkpoints (one is also written at every epoch's end)."""
    log_every: int = 50
    device: str = "cpu"


class Run:
    """The state of one training run (in one process): data, network, optimizer, history."""

    def __init__(self, cfg: TrainConfig,
                 place: distributed.Distributed = distributed.Distributed()):
        self.cfg, self.place = cfg, place
        self.device = place.device(cfg.device)
        if cfg.batch_size % place.world_size:
            raise ValueError(f"--batch-size {cfg.batch_size} is not divisible by the "
                             f"{place.world_size} processes")
        if cfg.albedo_loss not in ALBEDO_LOSSES:
            raise ValueError(f"albedo_loss {cfg.albedo_loss!r}: one of {ALBEDO_LOSSES}")
        if cfg.relit_loss_form not in RELIT_LOSS_FORMS:
            raise ValueError(f"relit_loss_form {cfg.relit_loss_form!r}: one of "
                             f"{RELIT_LOSS_FORMS}")
        if cfg.relit_partners not in RELIT_PARTNERS:
            raise ValueError(f"relit_partners {cfg.relit_partners!r}: one of {RELIT_PARTNERS}")
        if cfg.probe_tilts < 0 or not 0 <= cfg.max_probe_tilt <= 180:
            raise ValueError(f"probe_tilts {cfg.probe_tilts} must be >= 0 and max_probe_tilt "
                             f"{cfg.max_probe_tilt} within [0, 180] degrees")
        if cfg.dataset is None and cfg.labeled_maps is None:
            raise InputError(cfg.out, "give a dataset, labeled maps, or both")
        self.train_set = LabeledDataset(cfg.dataset, "train") if cfg.dataset else []
        self.test_set = LabeledDataset(cfg.dataset, "test") if cfg.dataset else []
        probe_files = find_probes(cfg.probes)
        self.probe_names = [path.stem for path in probe_files]
        radiances = [load_probe(path).radiance for path in probe_files]
        self.augmentation_probes = self._augmentation_probes()
        self._add_tilted_probes(radiances)
        self.probes = ProbeBank(radiances, device=self.device)
        if cfg.labeled_maps is not None:
            self.maps = MapSampler(cfg.labeled_maps, self.probes, self.augmentation_probes,
                                   cfg.network.input_size, cfg.render_size, cfg.max_view_angle,
                                   cfg.crop_scales, cfg.mix_specular)
            steps_per_epoch = cfg.epoch_samples // cfg.batch_size
            self.log_specular_range = self.maps.log_specular_range()
        else:
            self.maps = None
            self._check_dataset()
            steps_per_epoch = len(self.train_set) // cfg.batch_size
            log_specular = np.stack([self.train_set[i]["log_specular"]
                                     for i in range(len(self.train_set))])
            self.log_specular_range = (float(log_specular.min()), float(log_specular.max()))
        if steps_per_epoch < 1:
            raise InputError(cfg.labeled_maps or cfg.dataset,
                             f"fewer training samples than one minibatch of {cfg.batch_size}")
        self.unlabeled, self.unlabeled_indices = self._unlabeled()
        self.schedule = Schedule(steps_per_epoch, cfg.labeled_epochs, cfg.self_augmented_epochs,
                                 cfg.unlabeled_per_labeled if self.unlabeled is not None else 0)

        unknown = set(cfg.train_networks) - set(PARTS)
        if unknown or not cfg.train_networks:
            raise ValueError(f"train_networks {sorted(cfg.train_networks)}: name some of "
                             f"{', '.join(PARTS)}")
        if cfg.relit_loss_weight > 0 and not set(cfg.train_networks) & set(RELIT_NETWORKS):
            raise ValueError(f"the relit loss trains only the {' and '.join(RELIT_NETWORKS)} "
                             f"networks, and neither is trained")
        torch.manual_seed(cfg.seed)
        self.net = SVBRDFNet(cfg.network).to(self.device)
        if cfg.init_from is not None:
            self._initialize_from(cfg.init_from)
        self.frozen_parts = tuple(name for name in PARTS if name not in cfg.train_networks)
        for name in self.frozen_parts:
            getattr(self.net, name).requires_grad_(False)
        if place.enabled:
            distributed.synchronize_batch_norm(self.net)  # before the optimizer holds its weights
        self.model = self.net
        """What training steps call: the network, or its DistributedDataParallel wrapper."""
        self.optimizer, self.scheduler = make_optimizer(
            [p for p in self.net.parameters() if p.requires_grad], cfg.optimizer)
        self.step, self.history = 0, {"train": [], "test": []}

    def _initialize_from(self, model):
        """Load ``model``'s weights. Where its network configuration differs from this run's
        only in fields of FRESH_WHEN_CHANGED, the networks those fields shape start fresh (they
        must then be trained) and the others are loaded; a fresh photo-affine albedo network
        starts its analysis from the model's homogeneous analysis (both read a photo's
        homogeneous cues, and training on a CPU is short)."""
        start = load_network(model)
        config = self.cfg.network
        changed = [name for name in FRESH_WHEN_CHANGED
                   if getattr(start.config, name) != getattr(config, name)]
        if start.config != dataclasses.replace(config, **{name: getattr(start.config, name)
                                                          for name in changed}):
            raise InputError(model, f"its network {start.config} differs from this run's "
                                    f"{config}")
        fresh = {FRESH_WHEN_CHANGED[name] for name in changed}
        untrained = sorted(fresh - set(self.cfg.train_networks))
        if untrained:
            raise InputError(model, f"it differs from this run in {', '.join(changed)}: the "
                                    f"{', '.join(untrained)} network starts fresh and must be "
                                    "among the trained networks")
        for name in (name for name in PARTS if name not in fresh):
            getattr(self.net, name).load_state_dict(getattr(start, name).state_dict())
        if "albedo" in fresh and config.albedo_network == "photo-affine":
            self.net.albedo.affine.analysis.load_state_dict(
                start.homogeneous.analysis.state_dict())
        if fresh:
            log.info("%s: loaded all but the %s network, which starts fresh", model,
                     ", ".join(sorted(fresh)))

    def _check_dataset(self):
        cfg = self.cfg
        if len(self.train_set) < cfg.batch_size:
            raise InputError(cfg.dataset, f"{len(self.train_set)} training samples, fewer than "
                                          f"one minibatch of {cfg.batch_size}")
        size = self.train_set[0]["image"].shape[-1]
        if size != cfg.network.input_size:
            raise InputError(cfg.dataset, f"samples are {size}x{size}; the network takes "
                                          f"{cfg.network.input_size}x{cfg.network.input_size}")

    def _labeled_colors(self):
        """(N, 3) mean colors of labeled training images (for the unlabeled subset)."""
        if self.maps is not None:
            rng = np.random.default_rng([self.cfg.seed, LABELED_COLORS_STREAM])
            images = self.maps.batch(rng, 256)["image"]
            return images.mean((2, 3)).cpu().numpy()
        return np.stack([self.train_set[i]["image"].mean((1, 2))
                         for i in range(len(self.train_set))])

    def _augmentation_probes(self):
        """Indices of the probes self-augmentation (and ``labeled_maps``) renders under: those
        the dataset's training samples were rendered under (the test split's probes stay unseen
        in training), or every probe of the folder if it holds none of them or no dataset is
        given."""
        if self.cfg.dataset is None:
            return list(range(len(self.probe_names)))
        train_probes = {sample["probe"] for sample in self.train_set.samples}
        chosen = [i for i, name in enumerate(self.probe_names) if name in train_probes]
        if not chosen:
            log.warning("%s holds none of the dataset's training probes: self-augmentation "
                        "renders under all %d of its probes", self.cfg.probes,
                        len(self.probe_names))
            return list(range(len(self.probe_names)))
        return chosen

    def _add_tilted_probes(self, radiances):
        """Append ``cfg.probe_tilts`` tilted copies of each augmentation probe to
        ``radiances``, ``probe_names`` (the copy's name says its tilt and axis) and
        ``augmentation_probes``."""
        rng = np.random.default_rng([self.cfg.seed, PROBE_TILTS_STREAM])
        lowest_cosine = np.cos(np.radians(self.cfg.max_probe_tilt))
        for index in list(self.augmentation_probes):
            for _ in range(self.cfg.probe_tilts):
                tilt = round(float(np.degrees(np.arccos(rng.uniform(lowest_cosine, 1.0)))))
                azimuth = round(float(rng.uniform(0.0, 360.0)))  # whole degrees, as named
                radiances.append(tilted(radiances[index], tilt, azimuth))
                name = f"{self.probe_names[index]}-tilt{tilt}-axis{azimuth}"
                self.probe_names.append(name)
                self.augmentation_probes.append(len(radiances) - 1)

    def _unlabeled(self):
        if self.cfg.unlabeled is None:
            return None, None
        images = UnlabeledImages(self.cfg.unlabeled, self.cfg.network.input_size)
        try:
            chosen = select_matching(self._labeled_colors(), images.average_colors(),
                                     np.random.default_rng(self.cfg.seed),
                                     limit=self.cfg.unlabeled_limit)
        except ValueError as error:
            raise InputError(self.cfg.unlabeled, str(error)) from None
        log.info("unlabeled: %d of %d images follow the labeled color histogram",
                 len(chosen), len(images))
        return images, chosen

    def parallelize(self) -> None:
        """Under torchrun: wrap the network for data-parallel steps (after any resume: the
        wrapper starts from rank 0's weights)."""
        if self.place.enabled:
            self.model = torch.nn.parallel.DistributedDataParallel(self.net)

    def state(self) -> dict[str, Any]:
        return {"config": dataclasses.asdict(self.cfg), "model": self.net.state_dict(),
                "optimizer": self.optimizer.state_dict(),
                "scheduler": self.scheduler.state_dict(), "step": self.step,
                "torch_rng": torch.get_rng_state(), "history": self.history}

    def resume(self, path: str | Path) -> None:
        state = load_checkpoint(path)
        self.net.load_state_dict(state["model"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.scheduler.load_state_dict(state["scheduler"])
        torch.set_rng_state(state["torch_rng"])
        self.step, self.history = state["step"], state["history"]
        log.info("resumed from %s at step %d", path, self.step)

    def minibatch(self, index: int) -> dict[str, torch.Tensor | list[dict]]:
        """This process's shard of the (image, labels) minibatch of optimizer step ``index``.

        The global minibatch and its random choices are drawn from (seed, step) alone; each
        process then loads (and, self-augmenting, renders) only its shard."""
        step = self.schedule.step(index)
        rng = np.random.default_rng([self.cfg.seed, index])
        shard = self.place.shard
        if step.kind == SELF_AUGMENTED:
            chosen = rng.choice(self.unlabeled_indices, self.cfg.batch_size,
                                replace=len(self.unlabeled_indices) < self.cfg.batch_size)
            lightings = random_lightings(rng, self.cfg.batch_size, self.augmentation_probes,
                                         self.cfg.max_view_angle)
            photos = torch.as_tensor(np.stack([self.unlabeled.image(i) for i in shard(chosen)]))
            return self_augmented_batch(self.net, photos.to(self.device), self.probes,
                                        [shard(values) for values in lightings],
                                        self.log_specular_range)
        if self.maps is not None:
            return self.maps.batch(rng, self.cfg.batch_size, shard)
        indices = labeled_batch_indices(self.cfg.seed, step.epoch, step.batch,
                                        self.cfg.batch_size, len(self.train_set))
        return stack_items([self.train_set[int(i)] for i in shard(indices)], self.device)

    def train_step(self, index: int) -> dict[str, float]:
        """One optimizer step; returns the losses of the global minibatch."""
        return self.optimize(index, self.minibatch(index))

    def optimize(self, index: int,
                 batch: dict[str, torch.Tensor | list[dict]]) -> dict[str, float]:
        """The optimizer step ``index`` on ``batch`` (this process's shard of its minibatch);
        returns the losses of the global minibatch."""
        self.model.train()
        for name in self.frozen_parts:
            getattr(self.net, name).eval()  # frozen batch norm statistics
        prediction = self.model(batch["image"], parts=self.cfg.train_networks)
        terms = losses(prediction, batch, self.cfg.albedo_loss)
        if self.cfg.relit_loss_weight > 0:
            terms["relit"] = self._relit_loss(index, self._relit_estimate(prediction, batch),
                                              batch)
            terms["total"] = terms["total"] + self.cfg.relit_loss_weight * terms["relit"]
        self.optimizer.zero_grad(set_to_none=True)
        terms["total"].backward()
        self.optimizer.step()
        self.scheduler.step()
        self.step = index + 1
        return self.place.mean({name: value.detach().item() for name, value in terms.items()})

    def _relit_estimate(self, prediction, batch):
        """What the relit loss renders as the estimate: ``prediction``, the labels of the
        networks outside RELIT_NETWORKS detached, and the frozen networks' estimates added
        when the relit loss takes them as the partners (TrainConfig.relit_partners; computed
        without gradient, their batch norm in eval mode)."""
        estimate = {label: value if part in RELIT_NETWORKS else value.detach()
                    for part, labels in PARTS.items() for label in labels
                    if (value := prediction.get(label)) is not None}
        if self.cfg.relit_partners == "truth" or not self.frozen_parts:
            return estimate
        with torch.no_grad():
            partners = self.model(batch["image"], parts=self.frozen_parts)
        return partners | estimate

    def _relit_loss(self, index, prediction, batch):
        """The relit loss of step ``index``, under lightings drawn for the global minibatch
        (this process takes its shard)."""
        rng = np.random.default_rng([self.cfg.seed, index, RELIT_LOSS_STREAM])
        probe_index, rotation_deg, _ = random_lightings(rng, self.cfg.batch_size,
                                                        self.augmentation_probes)
        shard = self.place.shard
        return relit_loss(prediction, batch, self.probes, shard(probe_index),
                          shard(rotation_deg), self.cfg.relit_loss_size,
                          self.cfg.relit_loss_form)


def run(cfg: TrainConfig) -> dict[str, list[dict[str, float]]]:
    """Train (or resume) the run ``cfg``; returns its history."""
    place = distributed.start(cfg.device)
    try:
        return _train(cfg, place)
    finally:
        distributed.stop(place)


def _train(cfg, place):
    out = Path(cfg.out)
    run_state = Run(cfg, place)  # checks the inputs before anything is written
    may_change = MAY_CHANGE + (("labeled_epochs",) if labeled_phase_holds(
        out, run_state.schedule) else ())
    continue_folder(out, dataclasses.asdict(cfg), may_change, "sa-train", write=place.is_main)
    newest = checkpoint_files(out / "checkpoints")
    if newest:
        run_state.resume(newest[-1])
    run_state.parallelize()
    schedule = run_state.schedule
    log.info("%d steps of %d to go, %d epochs of %d steps, %d process(es)",
             schedule.total_steps - run_state.step, schedule.total_steps, schedule.epochs,
             schedule.steps_per_epoch, place.world_size)
    writer = SummaryWriter(str(out / "tensorboard")) if place.is_main else None
    interval, interval_start = [], time.perf_counter()
    with StopRequest() as stop:
        for index in range(run_state.step, schedule.total_steps):
            if place.any(stop.requested):
                break
            step = schedule.step(index)
            terms = run_state.train_step(index)
            if not place.is_main:
                continue
            interval.append((step.kind, terms))
            for name, value in terms.items():
                writer.add_scalar(f"train/{step.kind}/{name}", value, index + 1)
            writer.add_scalar("train/learning_rate", run_state.scheduler.get_last_lr()[0],
                              index + 1)
            checkpoint_due = (index + 1) % cfg.checkpoint_every == 0
            # A logged interval never spans a checkpoint, so a resumed run logs the same means.
            if (index + 1) % cfg.log_every == 0 or schedule.ends_epoch(index) or checkpoint_due:
                interval_start = _log_interval(run_state, interval, interval_start, index)
                interval = []
            if schedule.ends_epoch(index):
                _evaluate(run_state, writer, step.epoch)
                save_checkpoint(out / "checkpoints", run_state.state())
                interval_start = time.perf_counter()  # ms per step counts training steps only
            elif checkpoint_due:
                save_checkpoint(out / "checkpoints", run_state.state())
    stopped = run_state.step < schedule.total_steps
    if stopped and place.is_main:
        if interval:
            _log_interval(run_state, interval, interval_start, run_state.step - 1)
        if newest_step(out / "checkpoints") < run_state.step:
            save_checkpoint(out / "checkpoints", run_state.state())
    if writer is not None:
        writer.close()
    place.barrier()  # every process returns once the last checkpoint is written
    if stopped:
        raise TrainingStopped(stop.signal_number, run_state.step)
    return run_state.history


def labeled_phase_holds(out: Path, schedule: Schedule) -> bool:
    """Whether every step the run in ``out`` has taken (its newest checkpoint's) lies in the
    labeled phase of both the schedule it was started with and ``schedule``: its steps are then
    the same under either, since each step's data are drawn from (seed, step) and the learning
    rate depends on the step alone, so the run may continue with ``schedule``'s number of
    labeled epochs (a longer run, or a shorter one it has not passed). True where the folder
    has no checkpoint, or no readable config.json (continue_folder then says what is wrong)."""
    try:
        earlier = int(json.loads((out / "config.json").read_text())["labeled_epochs"])
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError):
        return True
    labeled_steps = schedule.steps_per_epoch * min(earlier, schedule.labeled_epochs)
    return newest_step(out / "checkpoints") <= labeled_steps


def _log_interval(run_state, interval, interval_start, index):
    """Log the mean losses of the interval per minibatch kind; return the new interval start."""
    now = time.perf_counter()
    ms_per_step = 1000.0 * (now - interval_start) / len(interval)
    left = (run_state.schedule.total_steps - index - 1) * ms_per_step / 1000.0
    record = {"step": index + 1, "epoch": run_state.schedule.step(index).epoch,
              "ms_per_step": ms_per_step}
    for kind in sorted({kind for kind, _ in interval}):
        values = [terms["total"] for k, terms in interval if k == kind]
        record[kind] = sum(values) / len(values)
    run_state.history["train"].append(record)
    losses_text = " ".join(f"{kind} {record[kind]:.4f}" for kind in sorted(record)
                           if kind not in ("step", "epoch", "ms_per_step"))
    log.info("step %d/%d epoch %d | loss %s | %.0f ms/step | %s left", index + 1,
             run_state.schedule.total_steps, record["epoch"], losses_text, ms_per_step,
             _duration(left))
    return now


def _evaluate(run_state, writer, epoch):
    cfg = run_state.cfg
    out = Path(cfg.out)
    if not len(run_state.test_set):
        log.info("epoch %d: no test samples (no dataset test split), evaluation skipped", epoch)
        write_json(out / "history.json", run_state.history)
        _plot_history(out / "loss_curves.png", run_state.history)
        return
    errors, example = evaluate(run_state.net, run_state.test_set, run_state.probes,
                               run_state.probe_names, cfg.batch_size, run_state.device)
    run_state.history["test"].append({"step": run_state.step, "epoch": epoch, **errors})
    for name, value in errors.items():
        writer.add_scalar(f"test/{name}", value, run_state.step)
    writer.add_image("test/examples", example, run_state.step)
    log.info("epoch %d test | %s", epoch, " ".join(f"{k} {v:.4g}" for k, v in errors.items()))
    with atomic_path(out / "examples.png") as tmp:
        Image.fromarray(np.round(example.numpy().transpose(1, 2, 0) * 255).astype(np.uint8)) \
            .save(tmp, format="PNG")
    write_json(out / "history.json", run_state.history)
    _plot_history(out / "loss_curves.png", run_state.history)


def _plot_history(path, history):
    figure = Figure(figsize=(11, 4))
    train_axis, test_axis = figure.subplots(1, 2)
    for kind in ("labeled", SELF_AUGMENTED):
        points = [(r["step"], r[kind]) for r in history["train"] if kind in r]
        if points:
            train_axis.plot(*zip(*points), label=f"{kind} minibatches")
    train_axis.set(xlabel="step", ylabel="training loss (sum of MSEs)", yscale="log")
    train_axis.legend()
    for name in ("albedo_mse", "log_specular_mse", "log_roughness_mse", "relit_mse"):
        test_axis.plot([r["step"] for r in history["test"]],
                       [r[name] for r in history["test"]], marker="o", label=name)
    test_axis.set(xlabel="step", ylabel="test error", yscale="log")
    test_axis.legend()
    figure.tight_layout()
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format="png", dpi=100)


def _duration(seconds):
    minutes, seconds = divmod(int(seconds), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}h{minutes:02d}m" if hours else f"{minutes}m{seconds:02d}s"
