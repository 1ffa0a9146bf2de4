"""The Python module's overhead on the operator's assembly: heat_laplacian on the flower at
h = 0.001 from C++ (build/bench/digilap-bench-operator-call) and from Python, each in a fresh
process, best of 5, with the growth of the peak resident set caused by the first call.

    PYTHONPATH=build/python python3 bench/python_overhead.py [build dir] [h]
"""
import os
import subprocess
import sys

build = sys.argv[1] if len(sys.argv) > 1 else "build"
h = sys.argv[2] if len(sys.argv) > 2 else "0.001"
python_call = f"""
import resource, time, digilap
digital = digilap.digitize(digilap.Flower(), {h})
contours = digilap.track_contours(digital)
mu = digilap.measures(contours, digilap.ii_normals(digital, contours))
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
best = 1e300
for k in range(5):
    t0 = time.perf_counter()
    op = digilap.heat_laplacian(contours, mu)
    best = min(best, time.perf_counter() - t0)
    if k == 0:
        growth = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    del op
print(f"{{best:.6f}} {{growth}}")
"""
env = dict(os.environ, PYTHONPATH=os.path.join(build, "python"))
rows = []
for run in range(3):
    cpp = subprocess.run([os.path.join(build, "bench", "digilap-bench-operator-call"), h], check=True, capture_output=True, text=True)
    py = subprocess.run([sys.executable, "-c", python_call], check=True, capture_output=True, text=True, env=env)
    (cs, cm), (ps, pm) = [line.split() for line in (cpp.stdout, py.stdout)]
    rows.append((float(cs), int(cm), float(ps), int(pm)))
print(f"heat_laplacian, flower, h = {h}, best of 5 calls per process, 3 processes each\n")
print("| run | C++ seconds | Python seconds | Python / C++ | C++ peak growth (MiB) | Python peak growth (MiB) |")
print("|---|---|---|---|---|---|")
for k, (cs, cm, ps, pm) in enumerate(rows):
    print(f"| {k + 1} | {cs:.4f} | {ps:.4f} | {ps / cs:.3f} | {cm / 1024:.1f} | {pm / 1024:.1f} |")
