"""radlab.load: a scene from a file or builtin spec with the command line's options, meshed, with
its per-element arrays as numpy."""

from . import _checks, _radlab


class Scene:
    """A loaded, meshed scene (what `radlab solve SCENE --subdiv ...` loads).

    Arrays: `areas` (n,) is a read-only view of radlab's own array (zero-copy, valid while the
    scene lives); `centroids`, `normals`, `rho`, `E` are (n, 3) float64 copies made on each access
    (a grey scene repeats its one channel, as `radlab solve --out` does). Matrices and the
    certified reference are computed on first use and kept (and cached on disk as by the CLI).
    """

    def __init__(self, handle, options):
        self._handle = handle
        self.options = options  # the load() arguments, as given

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
