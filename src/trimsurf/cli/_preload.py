"""``trimsurf tessellate``: load what the command will certainly run while the reader reads the first file.

A STEP, IGES or BREP file is read by a child of the reader server (`trimsurf.io._occ._isolate`); the
command itself only waits on a pipe, holding no lock and no CPU. Everything its first tessellation then
needs on top of the work itself is the same for every file (`trimsurf.tessellate`'s modules, numba's own
start -- its typing and target registries, the runtime it compiles once per process -- the 33 compiled
kernels every conforming tessellation with its report calls, `trimsurf.quality` and trimesh, which
reads the written mesh back): `Preload` does it in a thread during that wait. The command joins the
thread as soon as the read is done, before any work of its own, so that a forked worker (``--jobs``)
never inherits a running thread; whatever the thread had not finished then is waited for (reported as
``seconds_kernels_wait``). Kernels are loaded from numba's cache only (`trimsurf._numba_load.load_cached`):
a kernel not cached yet (a first run) is compiled by the tessellation that calls it, as before.
The outputs do not change: the same machine code runs, only loaded earlier.
"""

from __future__ import annotations

import gc
import threading
import time
from importlib import import_module

__all__ = ["KERNELS", "MODULES", "Preload"]

#: modules the first tessellation with its report imports (in this order; the kernels' modules come with them);
#: the written mesh is read back with trimesh, or meshio for its formats (`Preload`'s `read_back`)
MODULES = ("trimsurf.tessellate", "trimsurf.tessellate.measure", "trimsurf.quality", "trimsurf.io._meshfile")

#: the compiled kernels (numba dispatchers) that ``trimsurf tessellate`` calls on every model with shared edges,
#: with its report (measured: these 33 on each of occt__screw, trimesh__featuretype, gmsh__U_Joint_2, gmsh__t20_data,
#: gmsh__wrenchnut, occt__linkrods, one specialization each; `cell_surface_kernel`, called from Python only when
#: cells must be split (3 of the 6), is left to its call; tests/cli/test_preload.py checks the list against what
#: the command calls on the screw. s25-mesh: the face triangulation's kernels; `surface_distance_kernel` and
#: `deviation_samples` (curved faces whose triangles' start bound exceeds the tolerance) and
#: `_segments_apart_kernel` (trim loops not certainly simple) are left to their call, the screw calls none;
#: s25-edges: `pcurve_ends_kernel`, the segment ends of `repair.quick_repairs`; s25-seams: the seam reduction's
#: selection and its surface points of all faces in one call; s26-refine: refine_cells' rounds in one call,
#: `refine_cells_kernel`, in place of the cell kernels it calls, which the command no longer calls itself;
#: s26-seams: the seam reduction's flip and deviation tests (which call `_multi_derivatives_kernel` from compiled
#: code: left to its Python callers, the numpy paths) and its seam edges); s28-polylines: `loop_polylines_kernel` moved
#: to `geom._pcurve_kernels`, and the report's loop polygons sampled by it (`model.trim.loops_polylines`), so
#: `curve_points_kernel` is no longer called (measured on the six models above); s28-measure: `memo_points_kernel`,
#: the measurement's seed grids and (u, v) grids, and no `segments_distance_kernel`: the report's measurement no
#: longer computes the feet's distances outside the trim loops; s28-span: `span_bounds_kernel`, the report's
#: per-cell derivative bounds of each surface (`quality.interpolation_bound.span_bounds`); s29-mesh: the seam
#: reduction's vertices on two faces (`seams._multi_face_kernel`)
KERNELS = {
    "trimsurf.geom._nurbs_kernels": ("surface_derivatives_kernel", "project_newton_kernel"),
    "trimsurf.geom._seed_kernels": ("seed_grid_kernel", "retry_seeds_kernel", "memo_points_kernel"),
    "trimsurf.geom._pcurve_kernels": ("loop_polylines_kernel",),
    "trimsurf.geom.predicates": ("_slab_index", "_points_in_polygons_kernel"),
    "trimsurf.tessellate._line_kernels": ("inside_grids_kernel", "equidistributed_kernel", "line_net_kernel",
                                          "refine_cells_kernel"),
    "trimsurf.tessellate._chunk_kernels": ("discretize_chunks_kernel", "pcurve_ends_kernel"),
    "trimsurf.tessellate.grid": ("_domain_prepare_kernel", "_domain_finish_kernel"),
    "trimsurf.tessellate._mesh_kernels": ("lift_kernel", "face_loops_kernel", "cell_main_kernel", "curved_kernel"),
    "trimsurf.tessellate.slivers": ("_face_sliver_start_kernel", "_sliver_pick_kernel", "_sliver_result_kernel",
                                    "_corner_cosines", "_check_shape_kernel"),
    "trimsurf.tessellate.seams": ("_seam_select_kernel", "_dev_against_kernel", "_seam_edges_kernel",
                                  "_multi_face_kernel"),
    "trimsurf.quality._kernels": ("grid_build_kernel", "grid_closest_kernel", "hint_closest_kernel",
                                  "uv_locate_kernel"),
    "trimsurf.quality._bound_kernels": ("span_bounds_kernel",),
}


class Preload:
    """The preload thread: `start`, then `join` (returns the seconds waited for it).

    `read_back` is the module that will read the written mesh back ("trimesh", or "meshio" for its formats).

    Attributes after `join`: ``seconds`` (the thread's wall time), ``cpu_seconds`` (its own CPU time),
    ``waited`` (what `join` waited), ``loaded`` (kernel specializations loaded from the cache),
    ``error`` (an exception the thread stopped on, else None; the command then loads what is missing
    itself, as without preloading).
    """

    def __init__(self, read_back: str = "trimesh") -> None:
        self.modules = MODULES + (read_back,)
        self.seconds = self.cpu_seconds = self.waited = 0.0
        self.loaded = 0
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._joined = False
        self._thread = threading.Thread(target=self._run, name="trimsurf-preload", daemon=True)

    def start(self) -> Preload:
        self._thread.start()
        return self

    def _run(self) -> None:
        t0, c0 = time.perf_counter(), time.thread_time()
        # the cyclic GC off while the modules load (as the reader server imports): its full collections
        # would walk every object the imports have made so far, for the little garbage imports leave
        gc_was_on = gc.isenabled()
        gc.disable()
        try:
            from .._numba_load import load_cached

            for name in self.modules:
                if self._stop.is_set():
                    return
                import_module(name)
            for module, names in KERNELS.items():
                mod = import_module(module)
                for name in names:
                    if self._stop.is_set():
                        return
                    self.loaded += load_cached(getattr(mod, name))
        except BaseException as exc:  # noqa: BLE001 -- the command goes on; it loads what it needs itself
            self.error = exc
        finally:
            if gc_was_on:
                gc.enable()
            self.seconds = time.perf_counter() - t0
            self.cpu_seconds = time.thread_time() - c0

    def join(self, *, stop: bool = False) -> float:
        """Wait for the thread (after asking it to stop between two steps if `stop`); the seconds waited."""
        if stop:
            self._stop.set()
        if self._thread.ident is None or self._joined:
            return 0.0
        t = time.perf_counter()
        self._thread.join()
        self._joined = True
        self.waited = time.perf_counter() - t
        return self.waited
