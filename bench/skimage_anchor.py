"""bench_metrics' scikit-image anchor: SSIM or PSNR of two H x W x 3 float64 .npy images (display
values in [0, 1]) with the conformance set's settings (tests/unit/metrics_test.cpp): SSIM with
Gaussian weights, sigma 1.5, population covariance, data range 1, per channel then averaged; PSNR
with data range 1. Prints the value and the seconds the call took (reading the files not counted).

    python3 skimage_anchor.py ssim|psnr REF.npy TEST.npy
"""
import sys
import time

import numpy as np
from skimage.metrics import peak_signal_noise_ratio, structural_similarity


def main():
    metric, reference, test = sys.argv[1:4]
    ref, tst = np.load(reference), np.load(test)
    start = time.perf_counter()
    if metric == "ssim":
        value = structural_similarity(ref, tst, gaussian_weights=True, sigma=1.5,
                                      use_sample_covariance=False, data_range=1, channel_axis=2)
    elif metric == "psnr":
        value = peak_signal_noise_ratio(ref, tst, data_range=1)
    else:
        sys.exit(f"unknown metric {metric!r} (ssim or psnr)")
    seconds = time.perf_counter() - start
    print(f"{value:.9f} {seconds:.6f}")


if __name__ == "__main__":
    main()
