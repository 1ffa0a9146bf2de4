"""The operator's .npz files, read by SciPy and NumPy, equal its Matrix Market and CSV files
exactly (issue 12), and so do the same files in ZIP64 form (issue 23: what an operator above
4 GiB is written as; DIGILAP_ZIP64=1 writes every member so): run by ctest with the
digilap-operator app and a scratch directory."""
import os
import subprocess
import sys

import numpy as np
import scipy.io
import scipy.sparse

app, work = sys.argv[1], sys.argv[2]
for fmt in ("mtx", "npz"):
    subprocess.run([app, "--quiet", "--shape", "flower", "--h", "0.02", "--format", fmt, "--out", f"{work}/{fmt}"],
                   check=True, stdout=subprocess.DEVNULL)
subprocess.run([app, "--quiet", "--shape", "flower", "--h", "0.02", "--format", "npz", "--out", f"{work}/zip64"],
               check=True, stdout=subprocess.DEVNULL, env=dict(os.environ, DIGILAP_ZIP64="1"))
checks = 0
# The ZIP64 files: a ZIP64 end record and locator are there, and every array equals the plain one.
for name in ("L", "A", "M", "elements"):
    raw = open(f"{work}/zip64/{name}.npz", "rb").read()
    assert b"PK\x06\x06" in raw and b"PK\x06\x07" in raw, f"{name}.npz has no ZIP64 end record"
    assert raw != open(f"{work}/npz/{name}.npz", "rb").read()
    plain, wide = np.load(f"{work}/npz/{name}.npz"), np.load(f"{work}/zip64/{name}.npz")
    assert sorted(plain.files) == sorted(wide.files)
    for member in plain.files:
        assert np.array_equal(plain[member], wide[member]), (name, member)
    checks += 1
for name in ("L", "A", "M"):
    text = scipy.io.mmread(f"{work}/mtx/{name}.mtx").tocsr()
    binary = scipy.sparse.load_npz(f"{work}/npz/{name}.npz")
    assert binary.format == "csr", binary.format
    assert binary.shape == text.shape, (binary.shape, text.shape)
    assert binary.dtype == np.float64 and binary.indices.dtype == np.int32
    # Bit for bit: the text holds the shortest round-trip digits of every double.
    assert binary.nnz == text.nnz and (binary != text).nnz == 0, name
    assert np.array_equal(binary.data, text.data), name
    checks += 1
A = scipy.sparse.load_npz(f"{work}/npz/A.npz")
assert (A != A.T).nnz == 0, "A is not symmetric bit for bit"
checks += 1
elements = np.load(f"{work}/npz/elements.npz")
table = np.loadtxt(f"{work}/mtx/elements.csv", delimiter=",", skiprows=1)  # row,contour,index,x,y,mu,s
assert np.array_equal(elements["contour"], table[:, 1].astype(np.int64))
assert np.array_equal(elements["index"], table[:, 2].astype(np.int64))
assert np.array_equal(elements["positions"], table[:, 3:5])
assert np.array_equal(elements["mu"], table[:, 5]) and np.array_equal(elements["s"], table[:, 6])
checks += 1
print(f"{checks} passed, 0 failed")
