"""Running sweep chunks on Dask: :func:`connect_dask` opens (or takes) a client,
:func:`run_on_dask` maps a chunk function over its workers and hands each chunk's rows
back as it finishes. Needs ``dask.distributed`` (``pip install 'unidyn[dask]'``)."""

from __future__ import annotations

import os

from .._errors import MissingDependency
from .._validate import ValidationError

__all__ = ["connect_dask", "run_on_dask", "workers"]


def connect_dask(address, option: str = "dask_address"):
    """A ``distributed.Client`` for ``address`` and a function that closes what was
    opened here.

    :param address: ``"local"`` (a cluster of worker processes on this machine, at
        most two), a scheduler address (``"tcp://host:8786"``) or a
        ``distributed.Client`` (used as it is and left open)
    :param option: how the caller names the address in messages (``"--dask"``)
    :raises ValidationError: the address is not a string, or no scheduler answers there
    """
    try:
        import distributed
    except ImportError:
        raise MissingDependency("running a sweep on Dask needs dask.distributed "
                                "(pip install 'unidyn[dask]')") from None
    if isinstance(address, distributed.Client):
        return address, lambda: None
    if not isinstance(address, str) or not address.strip():
        raise ValidationError(f"{option} must be 'local' or a scheduler address (e.g. "
                              f"'tcp://host:8786'), or a distributed.Client; got {address!r}")
    address = address.strip()
    if address == "local":
        import logging
        workers = max(1, min(2, os.cpu_count() or 1))
        logging.getLogger("distributed").setLevel(logging.ERROR)
        cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1,
                                           processes=True, dashboard_address=None)
        client = distributed.Client(cluster)

        def close():
            client.close()
            cluster.close()

        return client, close
    try:
        client = distributed.Client(address, timeout="5s")
    except (OSError, TimeoutError, ValueError, TypeError) as err:
        detail = " ".join(str(err).split()) or type(err).__name__
        raise ValidationError(f"{option} {address}: cannot connect to a Dask scheduler there "
                              f"({detail[:300]}); give the address of a running scheduler "
                              f"(tcp://host:8786) or 'local'") from None
    return client, client.close


def workers(client) -> int:
    """The threads of ``client``'s workers, which run chunks at once (1 without a client)."""
    if client is None:
        return 1
    return max(1, sum(client.nthreads().values()))


def run_on_dask(client, run_chunk, chunks, take, **kwargs):
    """Run ``run_chunk(chunk, **kwargs)`` for every chunk of ``chunks`` (an iterable,
    read as the workers need more: two chunks per worker thread are out at a time, so
    that the memory here does not grow with the sweep) on ``client``'s workers, and
    call ``take(rows)`` with each result as it arrives; on any error or interrupt the
    chunks still out are cancelled."""
    from distributed import as_completed
    chunks = iter(chunks)
    out, queue = set(), as_completed()

    def submit() -> None:
        chunk = next(chunks, None)
        if chunk is not None:
            future = client.submit(run_chunk, chunk, **kwargs, pure=False)
            out.add(future)
            queue.add(future)

    try:
        for _ in range(2 * workers(client)):
            submit()
        for future in queue:
            out.discard(future)
            take(future.result())
            submit()
    except BaseException:
        client.cancel(list(out))
        raise
