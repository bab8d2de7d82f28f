"""scipy/numpy side of `twinscope bench`: times the same operations on the same input.

Usage: python3 scipy_reference.py DIR   (DIR holds x.f64, taps.f64, spec.json written by the bench)
Prints a JSON object {operation: median milliseconds, "versions": ...} on stdout.
"""
import json
import sys
import time
from pathlib import Path

import numpy as np
import scipy
import scipy.io
import scipy.signal as ss


def median_ms(fn, repeat):
    t = []
    for _ in range(max(1, repeat)):
        s = time.perf_counter()
        fn()
        t.append((time.perf_counter() - s) * 1e3)
    return float(np.median(t))


def kurtogram(x, fs, lengths):
    """The STFT kurtogram of `twinscope bench`: S4 / S2**2 - 2 per bin of scipy.signal.stft
    (hann, 75 % overlap, no padding) at every frame length."""
    out = []
    for n in lengths:
        _, _, z = ss.stft(x, fs, window="hann", nperseg=n, noverlap=3 * n // 4, boundary=None, padded=False, detrend=False)
        p = np.abs(z) ** 2
        out.append(np.mean(p * p, axis=1) / np.mean(p, axis=1) ** 2 - 2.0)
    return out


def main():
    d = Path(sys.argv[1])
    x = np.fromfile(d / "x.f64", dtype="<f8")
    taps = np.fromfile(d / "taps.f64", dtype="<f8")
    spec = json.loads((d / "spec.json").read_text())
    fs, r = spec["fs"], spec["repeat"]
    bands = [edge for band in spec["bands"] for edge in band]
    out = {
        "welch": median_ms(lambda: ss.welch(x, fs, window="hann", nperseg=4096), r),
        "hilbert": median_ms(lambda: np.abs(ss.hilbert(x)), r),
        "remez": median_ms(lambda: ss.remez(spec["numtaps"], bands, [0, 1, 0], weight=spec["weights"], fs=fs, maxiter=250), r),
        "filtfilt": median_ms(lambda: ss.filtfilt(taps, [1.0], x), r),
        "loadmat": median_ms(lambda: scipy.io.loadmat(spec["mat"]), r),
        "kurtogram": median_ms(lambda: kurtogram(x, fs, spec["kurtogram_lengths"]), r),
        "resample": median_ms(lambda: ss.resample(x, int(round(len(x) * 12000.0 / fs))), r),
        "versions": f"numpy {np.__version__}, scipy {scipy.__version__}, python {sys.version.split()[0]}",
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
