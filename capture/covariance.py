"""The cluster-robust covariance of the specular lobe's least-squares fits (:mod:`capture.phong`, :mod:`capture.pose`).

The high-passed lobe's residual is correlated between neighbouring pixels (the skin's texture at 2 px and
the high-pass itself), so the Gauss–Newton covariance understates a fit's uncertainty; the sandwich over
blocks of pixels that are nearly independent does not.
"""

from __future__ import annotations

import numpy as np

#: The blocks over which a lobe fit's residual scores are summed for its covariance (pixels, square).
#: The 2 px Gaussian high-pass (:data:`capture.lobe.LOBE_HIGH_PASS_PX`) correlates each residual value
#: with its neighbours over ±4σ = ±8 px, the skin's pores and fine blotches, which survive it, over
#: less; blocks of 16 px are as wide as that whole reach, so their sums are nearly independent, and a
#: lobe's high-passed core (10–60 px across at the bench's framing) still spans several.
BLOCK_PX = 16


def cluster_covariance(jac: np.ndarray, residual: np.ndarray, rows: np.ndarray, cols: np.ndarray,
                       block_px: int = BLOCK_PX) -> np.ndarray:
    """The cluster-robust covariance H⁻¹ (Σ_b g_b g_bᵀ) H⁻¹ · B/(B − 1) of a least-squares fit at its optimum.

    ``jac``: (P·C, K) the residual's Jacobian and ``residual``: (P·C,) the residual, pixel-major with C
    values per pixel; ``rows``, ``cols``: (P,) the pixels; g_b = J_bᵀ r_b summed over each square block of
    ``block_px`` pixels, B the number of blocks. Units: those of the parameters, squared.
    """
    n = len(rows)
    k = jac.shape[1]
    scores = np.einsum("pck,pc->pk", jac.reshape(n, -1, k), residual.reshape(n, -1))
    _, block = np.unique((rows // block_px).astype(np.int64) * (1 << 20) + cols // block_px, return_inverse=True)
    sums = np.zeros((int(block.max()) + 1, k))
    np.add.at(sums, block, scores)
    blocks = len(sums)
    bread = np.linalg.inv(jac.T @ jac)
    return bread @ (sums.T @ sums) @ bread * (blocks / max(blocks - 1, 1))
