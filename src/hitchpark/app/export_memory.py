"""The exported package's memory: upper bounds, known when generating it, of the bytes its structs take on any usual
ABI (each member rounded up to 8 bytes, no member aligned to more, pointers counted as 8, 8 more per struct for
its end). The C checks each bound when it compiles (``hitchpark_nmpc_ocp.inc``, ``hitchpark_nmpc.c``)."""

from __future__ import annotations

__all__ = ["block_bound", "workspace_bound"]


def _r8(n: int) -> int:
    return -(-n // 8) * 8


def block_bound(config: dict[str, int]) -> int:
    """Bytes that hold one OCP's block (its solver's work and arrays, ``hitchpark_nmpc_ocp.inc``) on any usual
    ABI: each member rounded up to 8 bytes (no member is aligned to more), pointers counted as 8, 8 more per
    struct for its end. The C checks it when it compiles."""
    N, nx, nu, nr = config["HP_N"], config["HP_NX"], config["HP_NU"], config["HP_NR"]
    nv, nra = nx + nu, max(nr, 1)
    nc = 2 * nr + 2 * nv
    nw, ng = (N + 1) * nv - nu, nx + N * nx + N * nr
    reals = (
        3 * nv + nc + 3 * nc + 4 * nc + nc + 4 * nc + 2 * nx + 2 + nv + 2 * nx + nx * nv + 2 * nra + nra * nx
        + 2 * nv * nv + nv + nx * nx + nx + nu * nu + nu * nx + 2 * nu + nx
    )  # fmt: skip
    stage = 8 * reals + _r8(nc) + 8
    work = (N + 1) * stage + 8 * (config["HP_SZ_ARG"] + config["HP_SZ_RES"] + config["HP_SZ_IW"] + config["HP_SZ_W"])
    work += 8 * nx + _r8(nx) + 8 + 8 * nx * nx + 16 + 16 * (config["HP_MAX_ITER"] + 1) + 8 + 16 + 8 + 8 + 8 + 8
    n_par = nx + N * config["HP_NP"] + config["HP_H0"]
    return _r8(work + 8 * (7 * nw + 6 * ng + n_par + 2) + 16 + 8)


def workspace_bound(
    blocks: dict[str, int], horizon: int, functions: dict[str, int], max_path: int, lines: int = 1
) -> int:
    """Bytes that hold the controller (``struct hitchpark_nmpc``): its shared part (``lines``: the numbers of a
    step's lines, 1 in open space), the path, and each OCP's block (``blocks``, by :func:`block_bound`), on any usual
    ABI as :func:`block_bound` counts; without the scene a package among obstacles adds."""
    nw = (horizon + 1) * 8 - 2
    shared = 8 * (nw + 6 + 6 * horizon + horizon * lines + 2) + 16 + 8 * sum(functions.values()) + 8
    return _r8(8 + shared + 16 + 16 + 8 + 8 + 8 * 6 * max_path + 8 * 5 + sum(map(_r8, blocks.values())) + 8)
