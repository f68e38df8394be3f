"""The few array operations the energies need, for numpy and for torch.

The energies in `pleat.physics.energies` are written once against this small namespace so the same code runs on
numpy float64 arrays (the simulator) and on torch tensors (training losses, with autograd). Only operations whose
meaning is identical in both are listed; anything else stays out of the energies.
"""
import numpy as np


class _NumpyOps:
    name = "numpy"

    @staticmethod
    def asarray(a, like=None):
        return np.asarray(a, dtype=np.float64)

    sqrt = staticmethod(np.sqrt)
    atan2 = staticmethod(np.arctan2)
    where = staticmethod(np.where)

    @staticmethod
    def relu(a):
        return np.maximum(a, 0.0)

    @staticmethod
    def clamp_min(a, lo):
        return np.maximum(a, lo)

    @staticmethod
    def sum(a, axis=None):
        return np.sum(a, axis=axis)

    @staticmethod
    def stack(arrays, axis=0):
        return np.stack(arrays, axis=axis)


class _TorchOps:
    name = "torch"

    @staticmethod
    def asarray(a, like=None):
        import torch
        if isinstance(a, torch.Tensor):
            return a if like is None else a.to(dtype=like.dtype, device=like.device)
        a = np.asarray(a)
        if like is None:
            return torch.as_tensor(a)
        if np.issubdtype(a.dtype, np.integer):
            return torch.as_tensor(a, device=like.device)
        return torch.as_tensor(a, dtype=like.dtype, device=like.device)

    @staticmethod
    def sqrt(a):
        import torch
        return torch.sqrt(a)

    @staticmethod
    def atan2(a, b):
        import torch
        return torch.atan2(a, b)

    @staticmethod
    def where(c, a, b):
        import torch
        return torch.where(c, a, b)

    @staticmethod
    def relu(a):
        import torch
        return torch.relu(a)

    @staticmethod
    def clamp_min(a, lo):
        import torch
        return torch.clamp(a, min=lo)

    @staticmethod
    def sum(a, axis=None):
        import torch
        return torch.sum(a) if axis is None else torch.sum(a, dim=axis)

    @staticmethod
    def stack(arrays, axis=0):
        import torch
        return torch.stack(arrays, dim=axis)


def namespace(x):
    """The ops namespace matching `x` (a numpy array or a torch tensor)."""
    if type(x).__module__.split(".")[0] == "torch":
        return _TorchOps
    return _NumpyOps


def dot(a, b):
    """Row-wise dot product over the last axis (…,3)·(…,3) → (…)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def cross(a, b, xp):
    """Row-wise cross product over the last axis, written with components so both namespaces agree."""
    return xp.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)
