"""Form-factor matrices as scipy.sparse, and the certified reference."""

import numpy as np

from . import _checks
from .scene import Scene


def _scene(scene):
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a radlab.Scene (from radlab.load), "
                        f"got {type(scene).__name__}")
    return scene._handle


def form_factors(scene, method=None, params=None, dense=False):
    """The form-factor matrix F (F[i, j] from element i to element j) of any registered method.

    Returns a scipy.sparse CSR matrix (a dense numpy array with dense=True) in float64: the
    matrix the certified reference is of (the method's F in double precision, symmetrised when
    the method's `symmetrise` parameter is on, its default with cached rows), whatever the
    runs' storage precision. Its `.diagnostics` (a dict)
    holds the row-sum range, the method's stated row-sum error, the reciprocity defect and the
    cache file. Matrices come from and go
    to the on-disk cache as the command line's do.
    """
    import scipy.sparse
    handle = _scene(scene)
    method = scene.options["ff_method"] if method is None else _checks.text("method", method)
    csr = handle.form_factors(method, _checks.assignments("params", params))
    n = csr["n"]
    matrix = scipy.sparse.csr_matrix((csr["data"], csr["indices"], csr["indptr"]), shape=(n, n))
    matrix.diagnostics = csr["diagnostics"]
    if dense:
        array = matrix.toarray()
        return DenseMatrix(array, csr["diagnostics"])
    return matrix


class DenseMatrix(np.ndarray):
    """A dense numpy matrix with the diagnostics of its build (`.diagnostics`)."""

    def __new__(cls, array, diagnostics):
        obj = np.asarray(array).view(cls)
        obj.diagnostics = diagnostics
        return obj

    def __array_finalize__(self, obj):
        self.diagnostics = getattr(obj, "diagnostics", None)


class Reference:
    """The certified reference (`radlab reference`): B (n x 3) and its bound.

    bound: certified ||B - B*||_inf (max over channels) for B* the exact solution of the
    discretised system; bound_relative: the same over max B*; summary: radlab's one-line text.
    """

    def __init__(self, fields):
        self.__dict__.update(fields)

    def __repr__(self):
        return f"radlab.Reference({self.summary})"


def reference(scene):
    """The certified reference of the scene's system (computed once, and cached on disk)."""
    return Reference(_scene(scene).reference())


def errors(scene, B):
    """Error metrics of any solution B ((n, 3) or, for a grey scene, (n,) float64) against the
    certified reference: rms, rms_rel (Cohen et al. 1988 eq. 14), p_mean, p_rms, p_max (Wu &
    Wang's p-error) on the mean of the channels, and max_relative = ||B - B*||_inf / max B*."""
    return _scene(scene).errors(B)
