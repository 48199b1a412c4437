"""radlab.load: a scene from a file or builtin spec with the command line's options, meshed, with
its per-element arrays as numpy; radlab.load_dict: the same from numpy arrays."""

import os
import tempfile

import numpy as np

from . import _checks, _radlab


class Scene:
    """A loaded, meshed scene (what `radlab solve SCENE --subdiv ...` loads).

    Arrays: `areas` (n,) is a read-only view of radlab's own array (zero-copy, valid while the
    scene lives); `centroids`, `normals`, `rho`, `E` are (n, 3) float64 copies made on each access
    (a grey scene repeats its one channel, as `radlab solve --out` does). Matrices and the
    certified reference are computed on first use and kept (and cached on disk as by the CLI).
    """

    def __init__(self, handle, options, files=None):
        self._handle = handle
        self.options = options  # the load() arguments, as given
        self._files = files  # load_dict's scene files: kept while the scene lives

    name = property(lambda self: self._handle.name, doc="the spec it was loaded from")
    size = property(lambda self: self._handle.size, doc="number of elements n")
    polygons = property(lambda self: self._handle.polygons, doc="number of input polygons")
    channels = property(lambda self: self._handle.channels, doc="1 (grey) or 3 (RGB)")
    areas = property(lambda self: self._handle.areas, doc="(n,) element areas, read-only view")
    centroids = property(lambda self: self._handle.centroids, doc="(n, 3) element centroids")
    normals = property(lambda self: self._handle.normals, doc="(n, 3) unit normals")
    rho = property(lambda self: self._handle.rho, doc="(n, 3) reflectance")
    E = property(lambda self: self._handle.E, doc="(n, 3) emission")
    polygon_of_element = property(lambda self: self._handle.polygon_of_element,
                                  doc="(n,) the input polygon of each element")

    def __len__(self):
        return self.size

    def __repr__(self):
        return (f"radlab.Scene({self.name!r}, {self.size} elements, {self.polygons} polygons, "
                f"{self.channels} channel{'s' if self.channels > 1 else ''})")


def load(scene, *, subdiv=1, element_size=0.0, patches="elements", patch_size=0.0,
         patch_rows="auto", keep_overlaps=False, ff="raycast", ff_set=None, precision="float",
         ff_mode="cached", cache=True, cache_dir=None, mgf_include_root=None):
    """Loads `scene` (a path, an open file, or 'builtin:NAME[:k=v,...]') and meshes it.

    The keywords are the command line's scene and form-factor options (`radlab solve --help`):
    subdiv (--subdiv), element_size (--element-size, 0: use subdiv), patches / patch_size /
    patch_rows (--patches, --patch-size, --patch-rows), keep_overlaps (--keep-overlaps), ff (--ff,
    the method of the runs' matrix), ff_set (--ff-set, a dict), precision (--precision float |
    double), ff_mode (--ff-mode cached | on-the-fly), mgf_include_root (--mgf-include-root);
    cache=False and cache_dir choose the on-disk cache (default $RADLAB_CACHE_DIR or
    ~/.cache/radlab).
    """
    spec = _checks.path("scene", scene)
    options = dict(subdiv=_checks.integer("subdiv", subdiv, 1),
                   element_size=_checks.number("element_size", element_size, minimum=0.0),
                   patches=_checks.choice("patches", patches, ["elements", "polygons", "size"]),
                   patch_size=_checks.number("patch_size", patch_size, minimum=0.0),
                   patch_rows=_checks.choice("patch_rows", patch_rows,
                                             ["auto", "centre", "mean"]),
                   keep_overlaps=bool(keep_overlaps),
                   ff_method=_checks.text("ff", ff),
                   ff_set=_checks.assignments("ff_set", ff_set),
                   precision=_checks.choice("precision", precision, ["float", "double"]),
                   ff_mode=_checks.choice("ff_mode", ff_mode, ["cached", "on-the-fly"]),
                   cache=bool(cache),
                   cache_dir="" if cache_dir is None else _checks.path("cache_dir", cache_dir))
    if mgf_include_root is not None:
        # Process-wide, as the command line's global option is.
        _radlab.set_mgf_include_root(_checks.path("mgf_include_root", mgf_include_root))
    handle = _radlab.SceneHandle(spec, **options)
    return Scene(handle, dict(scene=spec, **options))


def _float_array(name, value, columns, rows=None):
    """A finite float64 array of shape (N, columns), or (rows, columns) when rows is given (then
    also (rows,), repeated over the columns); anything else is a TypeError or ValueError."""
    if not isinstance(value, np.ndarray):
        raise TypeError(f"{name}: expected a numpy float64 array, got {type(value).__name__} "
                        "(convert with numpy.asarray(x, dtype=numpy.float64))")
    if value.dtype != np.float64:
        raise TypeError(f"{name}: expected a numpy float64 array, got dtype {value.dtype} "
                        "(radlab computes in float64; convert with x.astype(numpy.float64))")
    if rows is not None and value.shape == (rows,):
        value = np.repeat(value[:, None], columns, axis=1)
    if value.ndim != 2 or value.shape[1] != columns or (rows is not None
                                                         and value.shape[0] != rows):
        expected = f"(N, {columns})" if rows is None else f"({rows}, {columns}) or ({rows},)"
        raise ValueError(f"{name}: expected shape {expected}, got {value.shape}")
    bad = np.argwhere(~np.isfinite(value))
    if len(bad):
        row, column = bad[0]
        raise ValueError(f"{name}: row {row}, column {column} is {value[row, column]} (every "
                         "value must be finite)")
    return value


def load_dict(scene, **options):
    """A scene from arrays, as mi.load_dict makes one from a dict:

        radlab.load_dict({"vertices": V, "polygons": P, "rho": R, "E": E}, subdiv=4)

    vertices: (V, 3) float64 positions (m); polygons: a list of vertex-index lists (3 or more
    corners each, counter-clockwise seen from the front, which reflects and emits), or an
    (P, k) integer array; rho: (P, 3) or (P,) float64 reflectance in [0, 1]; E: (P, 3) or (P,)
    float64 emission >= 0. The keywords are load()'s. The arrays are written (exactly, %.17g) as
    an OBJ and MTL file in a temporary folder kept while the scene lives, and loaded by radlab's
    own reader and validation, so the scene is checked as a file would be (polygon p is material
    `polygon<p>` in its messages).
    """
    if not isinstance(scene, dict):
        raise TypeError(f"scene must be a dict with vertices, polygons, rho, E; "
                        f"got {type(scene).__name__}")
    keys = {"vertices", "polygons", "rho", "E"}
    if set(scene) != keys:
        raise ValueError(f"scene: keys must be exactly {sorted(keys)}; got {sorted(scene)}")
    vertices = _float_array("vertices", scene["vertices"], 3)
    polygons = scene["polygons"]
    if isinstance(polygons, np.ndarray):
        if polygons.dtype.kind not in "iu" or polygons.ndim != 2:
            raise TypeError(f"polygons: an array must be a 2-d integer array, got dtype "
                            f"{polygons.dtype} with shape {polygons.shape}")
        polygons = polygons.tolist()
    if not isinstance(polygons, (list, tuple)):
        raise TypeError(f"polygons must be a list of vertex-index lists or an integer array, "
                        f"got {type(polygons).__name__}")
    faces = []
    for p, polygon in enumerate(polygons):
        if not isinstance(polygon, (list, tuple, np.ndarray)) or len(polygon) < 3:
            raise ValueError(f"polygons[{p}]: expected a list of 3 or more vertex indices, "
                             f"got {polygon!r}")
        face = []
        for index in polygon:
            if isinstance(index, (bool, np.bool_)) or not isinstance(index, (int, np.integer)):
                raise TypeError(f"polygons[{p}]: vertex indices must be int, got "
                                f"{type(index).__name__} {index!r}")
            if not 0 <= index < len(vertices):
                raise ValueError(f"polygons[{p}]: vertex index {index} out of range "
                                 f"[0, {len(vertices)})")
            face.append(int(index))
        faces.append(face)
    rho = _float_array("rho", scene["rho"], 3, rows=len(faces))
    emission = _float_array("E", scene["E"], 3, rows=len(faces))
    if ((rho < 0) | (rho > 1)).any():
        p = int(np.argwhere((rho < 0) | (rho > 1))[0][0])
        raise ValueError(f"rho: polygon {p} has reflectance {rho[p].tolist()}, outside [0, 1]")
    if (emission < 0).any():
        p = int(np.argwhere(emission < 0)[0][0])
        raise ValueError(f"E: polygon {p} has emission {emission[p].tolist()}, below 0")

    files = tempfile.TemporaryDirectory(prefix="radlab-scene-")
    obj = os.path.join(files.name, "scene.obj")
    with open(os.path.join(files.name, "scene.mtl"), "w") as mtl:
        for p in range(len(faces)):
            mtl.write(f"newmtl polygon{p}\n"
                      f"Kd {rho[p, 0]:.17g} {rho[p, 1]:.17g} {rho[p, 2]:.17g}\n"
                      f"Ke {emission[p, 0]:.17g} {emission[p, 1]:.17g} {emission[p, 2]:.17g}\n")
    with open(obj, "w") as f:
        f.write("mtllib scene.mtl\n")
        for v in vertices:
            f.write(f"v {v[0]:.17g} {v[1]:.17g} {v[2]:.17g}\n")
        for p, face in enumerate(faces):
            f.write(f"usemtl polygon{p}\nf {' '.join(str(i + 1) for i in face)}\n")
    loaded = load(obj, **options)
    loaded._files = files
    return loaded
