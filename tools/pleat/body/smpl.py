"""Loader for SMPL-format model files (.npz, or .pkl as the SMPL release ships them) → `BodyModel`.

Keys: v_template [V,3], shapedirs [V,3,B], J_regressor [J,V] (dense or scipy sparse), weights [V,J],
kintree_table [2,J] (root parent −1 or 4294967295), f [F,3]. posedirs, if present, are ignored (the Pleat body
has no pose correctives). Official .pkl files hold chumpy arrays; those need the `chumpy` package to unpickle,
which this loader does not require for plain numpy/scipy pickles.
"""
import pickle
from pathlib import Path

import numpy as np

from pleat.body.model import BodyModel


def _plain(value):
    if hasattr(value, "toarray") or isinstance(value, np.ndarray):
        return value
    if hasattr(value, "r"):  # chumpy array: its value is .r
        return np.asarray(value.r)
    return np.asarray(value)


def load_smpl(path):
    path = Path(path)
    if path.suffix == ".npz":
        with np.load(path, allow_pickle=True) as z:
            arrays = {k: z[k] for k in z.files}
    elif path.suffix in (".pkl", ".pickle"):
        with open(path, "rb") as fh:
            arrays = pickle.load(fh, encoding="latin1")
        arrays = {k: _plain(v) for k, v in arrays.items() if k in (
            "v_template", "shapedirs", "J_regressor", "weights", "kintree_table", "f", "faces", "joint_names")}
    else:
        raise ValueError(f"unsupported SMPL model file {path} (expected .npz or .pkl)")
    missing = [k for k in ("v_template", "shapedirs", "J_regressor", "weights", "kintree_table") if k not in arrays]
    if missing or ("f" not in arrays and "faces" not in arrays):
        raise ValueError(f"{path}: not an SMPL model file (missing {missing or ['f']})")
    return BodyModel.from_arrays(arrays, source=f"SMPL-format file {path.name}")
