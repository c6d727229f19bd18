"""sgplvm: teach a family of robots the same motions from one set of human demonstrations.

A shared Gaussian-process latent variable model between human and robot joint spaces, with back
constraints on the human input, trained fully on one robot and transferred to others by training
only their latent-to-output mapping.

>>> import sgplvm
>>> m = sgplvm.SharedGPLVM(latent_dim=5, back_constraint="input", seed=0)   # doctest: +SKIP
>>> m.fit({"human": H, "walkman": R1}, input="human", validation="auto")   # doctest: +SKIP
>>> t = m.transfer("coman", R2)                                             # doctest: +SKIP
>>> t.predict(H_new, robot="coman")                                         # doctest: +SKIP
>>> arms = sgplvm.PartsGPLVM(parts="arms").fit({"human": H, "walkman": R1})  # doctest: +SKIP
"""

from ._sgplvm import Robot, __version__
from ._io import load_demonstrations, read_bvh, read_joint_states, retarget, simulate, write_joint_states
from ._model import DEFAULT_PATIENCE, SharedGPLVM
from ._regression import GPRegression
from ._parts import PartsGPLVM, load_model

__all__ = [
    "SharedGPLVM",
    "PartsGPLVM",
    "load_model",
    "GPRegression",
    "Robot",
    "load_demonstrations",
    "read_bvh",
    "read_joint_states",
    "retarget",
    "write_joint_states",
    "simulate",
    "DEFAULT_PATIENCE",
    "__version__",
]
