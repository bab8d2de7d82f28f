"""Estimates the CWRU 12 kHz recorder's anti-alias roll-off from the six 12k drive-end records.

Each record's Welch PSD (nperseg 4096, hann) in dB is referred to its mean level over
5000-5400 Hz; the mean of these roll-offs over 5400-6000 Hz is fitted with the model's
half-cosine-in-dB low-pass (twinscope::dsp::lowpass::lowpass_gain) by a grid search,
with the stopband edge at or below Nyquist (6 kHz).
Run from the project root: python3 assets/machines/cwru_antialias.py [DATA_DIR]
"""
import glob
import sys

import numpy as np
import scipy.io as sio
import scipy.signal as ss

data = sys.argv[1] if len(sys.argv) > 1 else "../shared/data/cwru"
rolloffs = []
for path in sorted(glob.glob(f"{data}/*_12k.mat")):
    d = sio.loadmat(path)
    x = d[[k for k in d if k.endswith("DE_time")][0]].ravel()
    f, p = ss.welch(x, 12000.0, nperseg=4096)
    db = 10 * np.log10(p)
    ref = db[(f >= 5000) & (f <= 5400)].mean()
    rolloffs.append(db - ref)
    print(f"{path.split('/')[-1]:34s}", " ".join(f"{a:.0f}:{(db - ref)[np.argmin(abs(f - a))]:6.1f}" for a in (5500, 5600, 5700, 5800, 5900, 5990)))
mean = np.mean(rolloffs, axis=0)
sel = (f >= 5400) & (f <= 6000)


def gain_db(fq, fp, fs_, a):
    u = np.clip((fq - fp) / (fs_ - fp), 0, 1)
    return -a * (1 - np.cos(np.pi * u)) / 2


best = min(
    ((np.sum((mean[sel] - gain_db(f[sel], fp, fst, a)) ** 2), fp, fst, a)
     for fp in range(5300, 5701, 25) for fst in range(5800, 6001, 25) for a in range(30, 81, 5) if fst > fp),
)
print(f"fit: passband_hz = {best[1]}, stopband_hz = {best[2]}, stopband_db = {best[3]}, rms misfit {np.sqrt(best[0] / sel.sum()):.1f} dB")
