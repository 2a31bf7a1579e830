"""Data-parallel training across processes: ``sa-train`` under ``torchrun``.

``torchrun --nproc_per_node N`` (on one or several nodes) starts N copies of ``sa-train`` with
``RANK``, ``WORLD_SIZE`` and ``LOCAL_RANK`` set. Each process then:

- takes its shard of every minibatch: ``batch_size`` stays the *global* minibatch, split into
  equal contiguous shards, one per rank (so the same seed gives the same samples per step,
  whatever the number of processes);
- computes its loss on its shard; DistributedDataParallel averages the gradients, which for
  equal shards of a mean loss is the gradient of the global minibatch;
- normalizes batch-norm layers with the statistics of the global minibatch
  (``SynchronizedBatchNorm2d``), so N processes train the same network as one process would.

Only rank 0 writes (checkpoints, logs, TensorBoard, pictures) and evaluates; checkpoints hold
the plain network, so a run resumes with any number of processes. Processes use the gloo
backend on CPUs; on GPUs, NCCL for the network's tensors and gloo for the few
numbers (losses, stop requests) they exchange on the CPU.
"""

import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import torch
import torch.distributed as dist
import torch.distributed.nn
from torch import nn

_Items = TypeVar("_Items", bound=Sequence | np.ndarray)
"""What Distributed.shard splits: a list (or other sequence) or an array."""


@dataclass(frozen=True)
class Distributed:
    """This process's place among the training processes (rank 0 of 1 without torchrun)."""
    rank: int = 0
    world_size: int = 1
    local_rank: int = 0

    @property
    def is_main(self) -> bool:
        """True for the process that writes files and evaluates."""
        return self.rank == 0

    @property
    def enabled(self) -> bool:
        return self.world_size > 1

    def shard(self, items: _Items) -> _Items:
        """This rank's contiguous share of a global minibatch (its length divisible by
        ``world_size``)."""
        size = len(items) // self.world_size
        return items[self.rank * size:(self.rank + 1) * size]

    def device(self, name: str) -> torch.device:
        """The torch device of this process: one GPU per process on CUDA."""
        if name.startswith("cuda") and self.enabled:
            return torch.device("cuda", self.local_rank)
        return torch.device(name)

    def mean(self, values: dict[str, float]) -> dict[str, float]:
        """Mean over the processes of a dict of floats (the same dict on one process)."""
        if not self.enabled:
            return values
        names = sorted(values)
        tensor = torch.tensor([values[name] for name in names], dtype=torch.float64)
        dist.all_reduce(tensor)
        return {name: float(value) / self.world_size for name, value in zip(names, tensor)}

    def any(self, flag: bool) -> bool:
        """Whether ``flag`` is true in any process (``flag`` itself on one process): every
        process gets the same answer, so all take the same branch."""
        if not self.enabled:
            return flag
        tensor = torch.tensor([int(flag)])
        dist.all_reduce(tensor, op=dist.ReduceOp.MAX)
        return bool(tensor.item())

    def barrier(self) -> None:
        if self.enabled:
            dist.barrier()


def start(device_name: str) -> Distributed:
    """Join the process group when started by torchrun; returns this process's Distributed."""
    world_size = int(os.environ.get("WORLD_SIZE", "1"))
    if world_size == 1:
        return Distributed()
    place = Distributed(int(os.environ["RANK"]), world_size, int(os.environ["LOCAL_RANK"]))
    if not dist.is_initialized():
        on_gpu = device_name.startswith("cuda")
        if on_gpu:
            torch.cuda.set_device(place.local_rank)
        # NCCL takes CUDA tensors only; gloo takes the CPU ones (Distributed.mean, .any).
        dist.init_process_group("cpu:gloo,cuda:nccl" if on_gpu else "gloo")
    return place


def stop(place: Distributed) -> None:
    if place.enabled and dist.is_initialized():
        dist.destroy_process_group()


class SynchronizedBatchNorm2d(nn.BatchNorm2d):
    """BatchNorm2d whose training statistics are those of the minibatch of all processes.

    torch.nn.SyncBatchNorm does the same on GPUs only; this one all-reduces the per-channel
    sums with torch.distributed.nn (differentiable, any backend), so CPU runs under gloo and GPU
    runs under NCCL take one code path. Outside distributed training, or in evaluation mode, it
    is a plain BatchNorm2d; its state dict is BatchNorm2d's.
    """

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # x: (B, C, H, W)
        if not (self.training and dist.is_available() and dist.is_initialized()
                and dist.get_world_size() > 1):
            return super().forward(x)
        channels = x.shape[1]
        count = torch.full((1,), x.numel() / channels, dtype=x.dtype, device=x.device)
        local = torch.cat([x.sum((0, 2, 3)), (x * x).sum((0, 2, 3)), count])
        total = torch.distributed.nn.all_reduce(local)  # sums over processes, with gradient
        samples = total[-1]
        mean = total[:channels] / samples
        variance = total[channels:2 * channels] / samples - mean * mean  # biased, as BN
        if self.track_running_stats:
            with torch.no_grad():
                self.num_batches_tracked.add_(1)
                unbiased = variance * samples / (samples - 1)
                self.running_mean.lerp_(mean, self.momentum)
                self.running_var.lerp_(unbiased, self.momentum)
        scale = self.weight * torch.rsqrt(variance + self.eps)
        shift = self.bias - mean * scale
        return x * scale[None, :, None, None] + shift[None, :, None, None]


def synchronize_batch_norm(module: nn.Module) -> nn.Module:
    """Replace every BatchNorm2d of ``module`` with a SynchronizedBatchNorm2d holding the same
    parameters and statistics; returns ``module``."""
    for name, child in module.named_children():
        if type(child) is nn.BatchNorm2d:
            synchronized = SynchronizedBatchNorm2d(child.num_features, child.eps, child.momentum,
                                                   child.affine, child.track_running_stats)
            synchronized.load_state_dict(child.state_dict())
            setattr(module, name, synchronized.to(child.weight.device))
        else:
            synchronize_batch_norm(child)
    return module
