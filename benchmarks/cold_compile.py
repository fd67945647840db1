"""Cold numba compile of a first tessellation: compile CPU seconds per dispatcher and its specializations.

    rm -rf /tmp/nc_x; NUMBA_CACHE_DIR=/tmp/nc_x PYTHONPATH=$PWD/src /work/main/.venv/bin/python benchmarks/cold_compile.py [measure]

Tessellates occt__screw.step (tolerance 1e-3 x diagonal, max_edge = diagonal; `measure` adds the report's
measurement) on whatever cache NUMBA_CACHE_DIR holds (empty = a user's first run), then prints the compile
seconds per dispatcher (inclusive: nested compiles counted in each caller; exclusive: minus nested ones),
every dispatcher compiled for more than one signature (a literal argument, int64 vs intp, C vs A or
readonly arrays each make another specialization), and the count of specializations. Times are CPU
(time.process_time) and noisy on a shared machine: compare two trees alternately.
"""
import time, collections, sys
from numba.core import event
acc = collections.defaultdict(float)
excl = collections.defaultdict(float); nsig = collections.Counter(); stack = []
class L(event.Listener):
    def __init__(self): self.st = {}
    def on_start(self, ev):
        self.st[id(ev.data['dispatcher']), str(ev.data['args'])] = time.process_time(); stack.append(0.0)
    def on_end(self, ev):
        k = (id(ev.data['dispatcher']), str(ev.data['args']))
        d = ev.data['dispatcher']; name = (d.py_func.__module__.split('.')[-1] + '.' + d.py_func.__name__)
        dt = time.process_time() - self.st.pop(k, time.process_time()); acc[name] += dt
        child = stack.pop(); excl[name] += dt - child; nsig[name] += 1
        if stack: stack[-1] += dt
lst = L(); event.register("numba:compile", lst)
t0 = time.process_time()
from pathlib import Path
from trimsurf.io import read_shell
from trimsurf.tessellate import tessellate_shell
shell = read_shell(Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad" / "occt__screw.step"); d = shell.diagonal()
t1 = time.process_time()
tessellate_shell(shell, tolerance=1e-3*d, max_edge=d, measure="measure" in sys.argv[1:])
t2 = time.process_time()
print("import+read", round(t1-t0,2), "tessellate", round(t2-t1,2), "compile total (nested counted twice)", round(sum(acc.values()),2))
for k, v in sorted(acc.items(), key=lambda kv: -kv[1])[:30]: print(f"{v:7.2f} {k}")
print("EXCLUSIVE total", round(sum(excl.values()),2))
for k, v in sorted(excl.items(), key=lambda kv: -kv[1])[:45]: print(f"{v:7.2f} {nsig[k]:3d} {k}")
import numba, gc
from numba.core.registry import CPUDispatcher
seen = set()
for o in gc.get_objects():
    if isinstance(o, CPUDispatcher) and id(o) not in seen:
        seen.add(id(o))
        if len(o.signatures) > 1:
            print("MULTI", o.py_func.__module__, o.py_func.__name__)
            for s in o.signatures: print("    ", s)
print("dispatchers", len(seen), "specializations", sum(len(o.signatures) for o in gc.get_objects() if isinstance(o, CPUDispatcher)))

