"""CDFF from Python: the data types, the DFNs and the errors of the C++ framework.

    import numpy as np, cdff
    canny = cdff.dfn.EdgeDetection("Canny", low_threshold=40)
    canny.image = cdff.Image(np.zeros((480, 640), np.uint8))   # shared, not copied
    canny.process()
    edges = canny.edges.array                                   # a read-only view

Data types cross to and from NumPy without a copy where the memory layout allows (docs/python.md)
and with a cdff.CopyWarning where it does not. A failed call raises a cdff.Error subclass (which
is also the matching built-in: InvalidInputError is a ValueError) whose text is the C++ message.
"""

from cdff import _core
from cdff._core import *  # noqa: F401,F403 (the data types, errors and helpers)
from cdff import dfn, dfpc, eval, io, sim  # noqa: F401  (eval: the module, not the built-in)

__version__ = _core.__version__

# The compiled classes present themselves as members of this package ("cdff.Image").
for _name in dir(_core):
    _obj = getattr(_core, _name)
    if isinstance(_obj, type) and getattr(_obj, "__module__", "") == "cdff._core":
        try:
            _obj.__module__ = "cdff"
        except (AttributeError, TypeError):
            pass

# What `from cdff import *` gives: the data types and errors, not the generated code's helpers.
__all__ = sorted(name for name in dir(_core)
                 if not name.startswith("_") and name not in ("input_port", "output_port"))
__all__ += ["dfn", "dfpc", "eval", "io", "sim"]
