"""scikit-learn objects as plain data and back, without pickle: an estimator becomes its class
name, its constructor parameters and its fitted attributes (arrays apart, numbers and strings in
JSON); it is rebuilt by calling the constructor of a class from a fixed list with those
parameters and setting the same attributes, so the rebuilt object runs scikit-learn's own
``predict``/``transform`` on identical data and gives bit-for-bit the same results.

Only the classes listed in ``ESTIMATORS`` and ``KERNELS`` are ever constructed; a file naming any
other class is refused. Values are tagged so that types survive JSON: numpy scalars keep their
dtype, tuples stay tuples (kernel bounds), small arrays inside kernels (anisotropic length
scales) are written in full (Python's float repr reads back exactly).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from sklearn.decomposition import PCA
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process import kernels as gp_kernels

__all__ = ["ESTIMATORS", "KERNELS", "decode_value", "encode_value", "estimator_from_state", "estimator_state"]

ESTIMATORS: dict[str, type] = {"PCA": PCA, "GaussianProcessRegressor": GaussianProcessRegressor}
KERNELS: dict[str, type] = {
    cls.__name__: cls
    for cls in (
        gp_kernels.ConstantKernel,
        gp_kernels.Matern,
        gp_kernels.RBF,
        gp_kernels.WhiteKernel,
        gp_kernels.RationalQuadratic,
        gp_kernels.DotProduct,
        gp_kernels.ExpSineSquared,
        gp_kernels.Sum,
        gp_kernels.Product,
        gp_kernels.Exponentiation,
    )
}
# state that is not kept: the random generator a GP used for its optimiser restarts (fitting only)
NOT_SAVED = frozenset({"_rng"})
_NUMPY_SCALARS = ("float64", "float32", "int64", "int32", "bool")


def encode_value(value: Any, where: str) -> Any:
    """``value`` as JSON-ready data with type tags; ``where`` names it in errors."""
    if value is None or (isinstance(value, bool | int | float | str) and not isinstance(value, np.generic)):
        return value
    if isinstance(value, np.generic):
        if value.dtype.name not in _NUMPY_SCALARS:
            raise TypeError(f"{where}: numpy scalar of dtype {value.dtype} cannot be saved")
        return {"__numpy__": value.dtype.name, "value": value.item()}
    if isinstance(value, tuple):
        return {"__tuple__": [encode_value(v, f"{where}[{i}]") for i, v in enumerate(value)]}
    if isinstance(value, list):
        return [encode_value(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, np.ndarray):
        if value.dtype.name not in _NUMPY_SCALARS:
            raise TypeError(f"{where}: array of dtype {value.dtype} cannot be saved")
        return {"__array__": value.tolist(), "dtype": value.dtype.name, "shape": list(value.shape)}
    if isinstance(value, gp_kernels.Kernel):
        name = type(value).__name__
        if KERNELS.get(name) is not type(value):
            raise TypeError(f"{where}: kernel {name} is not one of {', '.join(KERNELS)}")
        params = value.get_params(deep=False)
        return {"__kernel__": name, "params": {k: encode_value(v, f"{where}.{k}") for k, v in params.items()}}
    raise TypeError(f"{where}: a {type(value).__name__} cannot be saved")


def decode_value(data: Any, where: str) -> Any:
    """The inverse of :func:`encode_value`; only listed kernel classes are constructed."""
    if data is None or isinstance(data, bool | int | float | str):
        return data
    if isinstance(data, list):
        return [decode_value(v, f"{where}[{i}]") for i, v in enumerate(data)]
    if not isinstance(data, dict):
        raise TypeError(f"{where}: unexpected {type(data).__name__}")
    if "__numpy__" in data:
        if data["__numpy__"] not in _NUMPY_SCALARS:
            raise TypeError(f"{where}: numpy scalar type {data['__numpy__']!r} is not allowed")
        return np.dtype(data["__numpy__"]).type(data["value"])
    if "__tuple__" in data:
        return tuple(decode_value(v, f"{where}[{i}]") for i, v in enumerate(data["__tuple__"]))
    if "__array__" in data:
        if data.get("dtype") not in _NUMPY_SCALARS:
            raise TypeError(f"{where}: array dtype {data.get('dtype')!r} is not allowed")
        array = np.array(data["__array__"], dtype=data["dtype"]).reshape(data["shape"])
        return array
    if "__kernel__" in data:
        cls = KERNELS.get(data["__kernel__"])
        if cls is None:
            raise TypeError(f"{where}: kernel {data['__kernel__']!r} is not one of {', '.join(KERNELS)}")
        return cls(**{k: decode_value(v, f"{where}.{k}") for k, v in data["params"].items()})
    raise TypeError(f"{where}: unknown tagged value with keys {sorted(data)}")


def estimator_state(estimator: Any, prefix: str) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(JSON-ready description, arrays named ``prefix.<attribute>``) of a fitted estimator of a
    class in ``ESTIMATORS``. Every attribute is kept but ``NOT_SAVED``; one that cannot be
    written raises, so nothing is dropped silently."""
    name = type(estimator).__name__
    if ESTIMATORS.get(name) is not type(estimator):
        raise TypeError(f"{prefix}: {name} is not one of {', '.join(ESTIMATORS)}")
    params = estimator.get_params(deep=False)
    config: dict[str, Any] = {
        "class": name,
        "params": {k: encode_value(v, f"{prefix}.{k}") for k, v in params.items()},
        "attributes": {},
        "arrays": [],
    }
    arrays: dict[str, np.ndarray] = {}
    for attr, value in vars(estimator).items():
        if attr in params or attr in NOT_SAVED:
            continue
        if isinstance(value, np.ndarray) and value.ndim > 0:
            arrays[f"{prefix}.{attr}"] = value
            config["arrays"].append(attr)
        else:
            config["attributes"][attr] = encode_value(value, f"{prefix}.{attr}")
    return config, arrays


def estimator_from_state(config: dict[str, Any], arrays: dict[str, np.ndarray], prefix: str) -> Any:
    """The estimator described by :func:`estimator_state`'s output."""
    cls = ESTIMATORS.get(config["class"])
    if cls is None:
        raise TypeError(f"{prefix}: class {config['class']!r} is not one of {', '.join(ESTIMATORS)}")
    params = {k: decode_value(v, f"{prefix}.{k}") for k, v in config["params"].items()}
    estimator = cls(**params)
    for attr in [*config["attributes"], *config["arrays"]]:
        if not attr.isidentifier() or attr.startswith("__") or callable(getattr(cls, attr, None)):
            raise TypeError(f"{prefix}: {attr!r} is not a fitted attribute of {cls.__name__}")
    for attr, value in config["attributes"].items():
        setattr(estimator, attr, decode_value(value, f"{prefix}.{attr}"))
    for attr in config["arrays"]:
        key = f"{prefix}.{attr}"
        if key not in arrays:
            raise KeyError(f"array {key!r} missing")
        setattr(estimator, attr, arrays[key])
    return estimator
