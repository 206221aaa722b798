"""A local dask cluster of single-threaded processes: what averaging on dask and an
ensemble of simulations both start when no scheduler is given (granavg has no scheduler
of its own)."""

from __future__ import annotations


def local_cluster(workers: int):
    """A local dask cluster of ``workers`` single-threaded processes. glibc's default
    malloc trim threshold is kept (dask lowers it to 64 kB, which made a worker's frames
    1.2x slower here: the reader's 8 MB buffers went back to the OS every time)."""
    import dask
    from dask.distributed import LocalCluster

    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_":
                          128 << 20}):
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                            dashboard_address=None)
