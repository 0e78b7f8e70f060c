"""scipy's shift-invert eigsh on the scale benchmark's plate (docs/performance.md):
the 10 lowest modes of K phi = omega^2 M phi, the tool a user would otherwise
script. Prints one JSON line: read and eigsh wall times [s], omega [rad/s]."""
import json
import sys
import time

import numpy as np
import scipy.io
import scipy.sparse.linalg as sla


def main(folder: str, n_modes: int = 10) -> None:
    t0 = time.perf_counter()
    m = scipy.io.mmread(f"{folder}/plate_M.mtx").tocsc()
    k = scipy.io.mmread(f"{folder}/plate_K.mtx").tocsc()
    t1 = time.perf_counter()
    lam = sla.eigsh(k, k=n_modes, M=m, sigma=0.0, which="LM", return_eigenvectors=False)
    t2 = time.perf_counter()
    omega = np.sqrt(np.sort(lam))
    print(json.dumps({"ndof": k.shape[0], "read_s": t1 - t0, "eigsh_s": t2 - t1,
                      "omega_rad_s": omega.tolist()}))


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 10)
