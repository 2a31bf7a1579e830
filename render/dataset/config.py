"""The configuration of ``render-dataset`` (render.dataset.generator): every option, resolved,
as the run writes it to ``config.json``."""

from dataclasses import dataclass

from render.common.exposure import DEFAULT_KEY
from render.mitsuba_reference.scene import DEFAULT_SAMPLER


@dataclass(frozen=True)
class DatasetConfig:
    probes: str
    """Folder of equirectangular HDR probes (.exr, .hdr)."""
    svbrdfs: str
    """Folder with one sub-folder per material (maps and optional material.json)."""
    out: str
    """Output dataset folder; re-running with the same options resumes an interrupted run."""
    resolution: int = 256
    """Side of each output sample in pixels."""
    render_size: int = 512
    """Shorter side of the rendered canvas; material maps are resampled to it."""
    rotations: int = 9
    """Random probe rotations (renders) per (material, probe), as in the paper."""
    crops: int = 4
    """Random crops (each with a random quarter turn) cut from each render."""
    spp: int = 1024
    """Samples per pixel of each render."""
    sampler: str = DEFAULT_SAMPLER
    """Mitsuba sampler plugin (stratified kinds converge much faster than 'independent')."""
    seed: int = 0
    """Seed of every random choice; the same seed gives the same dataset."""
    workers: int = 1
    """Worker processes rendering tasks in parallel (with ``ray="local"``: the CPUs of the
    local Ray instance)."""
    ray: str | None = None
    """None: render on this machine. Otherwise render as Ray tasks (render/dataset/ray_runner.py)
    on the cluster at this address (``auto``, ``HOST:6379``, ``ray://HOST:10001``), or on a
    Ray instance started on this machine for ``local``."""
    ray_chunk: int = 4
    """Tasks (material, probe, rotation) per Ray task."""
    ray_cpus_per_task: int = 1
    """CPUs each Ray task reserves, and the Mitsuba threads it renders with."""
    variant: str = "llvm_ad_rgb"
    """Mitsuba variant, e.g. llvm_ad_rgb (CPU) or cuda_ad_rgb (GPU)."""
    test_materials: float = 0.2
    """Fraction of materials held out for the test split."""
    test_probes: float = 0.2
    """Fraction of probes held out for the test split (test samples pair test materials with
    test probes; mixed pairs are not rendered)."""
    exposure_key: float = DEFAULT_KEY
    """Mean luminance of each exposed sample before clamping to [0, 1]."""
    max_view_angle: float = 0.0
    """Largest angle in degrees between the view and the normal; 0 is fronto-parallel."""

    def validate(self) -> None:
        if self.resolution < 8:
            raise ValueError("--resolution must be at least 8")
        if self.render_size < self.resolution:
            raise ValueError("--render-size must be at least --resolution")
        for name in ("rotations", "crops", "spp", "workers", "ray_chunk", "ray_cpus_per_task"):
            if getattr(self, name) < 1:
                raise ValueError(f"--{name} must be at least 1")
        if not (0 <= self.test_materials < 1 and 0 <= self.test_probes < 1):
            raise ValueError("--test-materials and --test-probes must be in [0, 1)")
        if not 0 <= self.max_view_angle < 90:
            raise ValueError("--max-view-angle must be in [0, 90)")
