"""Scale-out on Dask: one record split across workers, and many loops at once.

Install the optional extra: ``pip install "lifted[dask]"`` (``dask[distributed]``).

:func:`identify` identifies one record stored as shards (a dask array, a dask
DataFrame, or a list of ``.npy`` / Parquet files) by the plan of
:func:`lifted.identify`: a record of up to :data:`IN_MEMORY_BYTES` (16 MiB of
float64 samples) is gathered to the client and identified by that function
itself, with its options and defaults, so the model is the same bit for bit;
a larger record runs the sharded engine without gathering it: each
shard is compressed on the worker that holds it into lagged correlation sums
(O(s (m+p)^2) floats, a few kB), the pieces are merged in a tree of
adjacent pairs (the merge is associative: each join adds the products that
straddle the shard boundary), the subspace step runs on the client from the
merged k x k matrix, and the output-error (B, D, x0) regression of the
default route makes a second pass: each shard's regression rows are
reduced to R factors on its worker from the regressor filters' state at
the shard's start, and the R factors merge in a tree. For shard files that
state is the one the filters reach over the last few hundred samples
before the shard (they forget their start within
``ceil(ln 1e-30 / ln rho(A)) + 1`` samples, 657 for rho = 0.9:
``lifted_subspace::OutputErrorStream::memory``), so the shards are scanned
independently and each is read once per pass; when the filters do not
forget (a pole on or near the unit circle) or the shards are not files, the
state goes from shard to shard in record order (filtering only, ~2 n m
flops per sample) and each shard is read twice. ``.npy`` shards are read in
Rust by the command's reader, block by block, straight into the
compression and the regression (one block in memory, no numpy copy). The
model is the one-process streaming identification of the whole record up
to rounding (``lifted_subspace::CompressedRecords``,
``lifted_subspace::RegressionPiece``); ``diagnostics["engine"]`` says how
the second pass ran.

:func:`identify_many` identifies many independent loops, one task each, and
returns every model and every failure by name (a bad loop never loses the
others).

Both take ``client=``: a ``dask.distributed.Client``, a scheduler address
(``"tcp://10.0.0.5:8786"``), or None for the current default scheduler::

    from dask.distributed import Client, LocalCluster
    client = Client(LocalCluster(n_workers=4))        # on this machine
    # client = Client("tcp://scheduler:8786")          # an existing cluster
    fit = lifted.dask.identify(["hist-000.npy", "hist-001.npy"],
                               inputs=[0, 1], outputs=[2, 3], order=4,
                               client=client)
"""

from __future__ import annotations

import importlib
import os
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from . import _lifted, _subspace_fit
from ._lifted import LiftedError
from ._results import SubspaceFit

__all__ = ["identify", "identify_many", "ManyResult", "compress_shards"]


def _module(name: str) -> Any:
    """An optional dependency, imported when first used (typed as Any: dask
    and pandas ship no complete annotations)."""
    try:
        return importlib.import_module(name)
    except ImportError as e:  # pragma: no cover - exercised without dask only
        raise ImportError(
            f"lifted.dask needs {name.split('.')[0]}: pip install 'lifted[dask]' (dask[distributed,dataframe])"
        ) from e


def _dask() -> Any:
    """``dask.delayed``."""
    return _module("dask").delayed


def _client(client: Any) -> Any:
    """A Client from a Client, an address string, or None (default scheduler)."""
    if client is None or not isinstance(client, str):
        return client
    return _module("dask.distributed").Client(client)


def _compute(client: Any, *objs: Any) -> tuple[Any, ...]:
    if client is None:
        return tuple(_module("dask").compute(*objs))
    futures = client.compute(list(objs))
    return tuple(client.gather(futures))


# ---------------------------------------------------------------- shards


def _columns(block: np.ndarray, cols: Sequence[int], name: str) -> np.ndarray:
    if block.ndim == 1:
        block = block.reshape(-1, 1)
    if block.ndim != 2:
        raise LiftedError(f"shard must be 2-D (samples x columns), got {block.ndim} dimensions")
    try:
        out = block[:, list(cols)]
    except IndexError as e:
        raise LiftedError(f"{name} columns {list(cols)} not in a shard of {block.shape[1]} columns") from e
    if np.iscomplexobj(out):
        raise LiftedError(f"{name}: complex data is not supported")
    return np.ascontiguousarray(out, dtype=np.float64)


@dataclass(frozen=True)
class _FileShard:
    """A shard file, read inside each task that uses it (so a worker holds
    one shard per running task, not every shard it was given)."""

    path: str
    inputs: tuple[Any, ...]
    outputs: tuple[Any, ...]

    def load(self) -> tuple[Any, Any]:
        if self.npy:
            return _load_npy(self.path, self.inputs, self.outputs)
        return _load_parquet(self.path, self.inputs, self.outputs)

    @property
    def npy(self) -> bool:
        return self.path.endswith(".npy")

    def rows(self, start: int, stop: int | None) -> tuple[Any, Any]:
        """Samples ``start:stop`` only: a ``.npy`` file reads just those rows
        (memory-mapped), a Parquet file the row groups that hold them."""
        if self.npy:
            a = np.load(self.path, mmap_mode="r")[start:stop]
            return _columns(a, self.inputs, "inputs"), _columns(a, self.outputs, "outputs")
        pq = _module("pyarrow.parquet")
        f = pq.ParquetFile(self.path)
        meta = f.metadata
        stop = meta.num_rows if stop is None else min(stop, meta.num_rows)
        # The row groups that overlap start:stop, and where the first begins.
        groups: list[int] = []
        first = at = 0
        for g in range(meta.num_row_groups):
            n = meta.row_group(g).num_rows
            if at + n > start and at < stop:
                if not groups:
                    first = at
                groups.append(g)
            at += n
        names = list(self.inputs) + list(self.outputs)
        df = f.read_row_groups(groups, columns=names).to_pandas()[start - first:stop - first]
        return _frame(df, self.inputs, self.outputs)


def _data(shard: Any) -> tuple[Any, Any]:
    """The (u, y) of a shard: a file read now, or a computed block."""
    return shard.load() if isinstance(shard, (_FileShard, _Scaled)) else shard


@dataclass(frozen=True)
class _Scaled:
    """A shard whose channels are divided by the record's channel scales
    (the workflow's, ``lifted._lifted.channel_scales``: what
    :func:`lifted.identify` divides by, so both give the same model)."""

    shard: Any
    su: tuple[float, ...]
    sy: tuple[float, ...]

    def load(self) -> tuple[Any, Any]:
        return _scale_pair(_data(self.shard), self.su, self.sy)

    def rows(self, start: int, stop: int | None) -> tuple[Any, Any]:
        return _scale_pair(_rows_of(self.shard, start, stop), self.su, self.sy)


def _rows_of(shard: Any, start: int, stop: int | None) -> tuple[Any, Any]:
    """Samples ``start:stop`` of a shard, reading no more of a file than
    that (a computed block is sliced)."""
    if isinstance(shard, (_FileShard, _Scaled)):
        return shard.rows(start, stop)
    u, y = _data(shard)
    return u[start:stop], y[start:stop]


def _npy_file(shard: Any) -> tuple[_FileShard, tuple[float, ...], tuple[float, ...]] | None:
    """A ``.npy`` file shard (scaled or not) with its channel scales: read
    in Rust by the command's reader, no numpy copies."""
    if isinstance(shard, _Scaled) and isinstance(shard.shard, _FileShard) and shard.shard.npy:
        return shard.shard, shard.su, shard.sy
    if isinstance(shard, _FileShard) and shard.npy:
        return shard, (1.0,) * len(shard.inputs), (1.0,) * len(shard.outputs)
    return None


def _scale_pair(pair: tuple[Any, Any], su: tuple[float, ...], sy: tuple[float, ...]) -> tuple[Any, Any]:
    """A computed block (u, y) divided by the channel scales."""
    u, y = pair
    return np.asarray(u, dtype=np.float64) / np.asarray(su), np.asarray(y, dtype=np.float64) / np.asarray(sy)


def _head(shard: Any, rows: int) -> tuple[Any, Any]:
    """The first ``rows`` samples of a shard (u, y)."""
    u, y = _rows_of(shard, 0, rows)
    return np.asarray(u, dtype=np.float64), np.asarray(y, dtype=np.float64)


def _channel_scales(shards: list[Any], client: Any) -> tuple[list[float], list[float]]:
    """The record's channel scales from its first 1e4 samples (across the
    first shards when they are shorter)."""
    delayed = _dask()
    need = 10_000
    us: list[Any] = []
    ys: list[Any] = []
    for s in shards:
        (head,) = _compute(client, delayed(_head)(s, need))
        us.append(head[0])
        ys.append(head[1])
        need -= len(head[0])
        if need <= 0:
            break
    su, sy = _lifted.channel_scales(np.vstack(us), np.vstack(ys))
    return list(su), list(sy)


def _load_npy(path: str, inputs: Sequence[int], outputs: Sequence[int]) -> tuple[Any, Any]:
    a = np.load(path, mmap_mode="r")
    return _columns(a, inputs, "inputs"), _columns(a, outputs, "outputs")


def _load_parquet(path: str, inputs: Sequence[str], outputs: Sequence[str]) -> tuple[Any, Any]:
    df = _module("pandas").read_parquet(path, columns=list(inputs) + list(outputs))
    return _frame(df, inputs, outputs)


def _frame(df: Any, inputs: Sequence[str], outputs: Sequence[str]) -> tuple[Any, Any]:
    missing = [c for c in list(inputs) + list(outputs) if c not in df.columns]
    if missing:
        raise LiftedError(f"columns {missing} not in the data (columns: {list(df.columns)[:20]})")
    u = np.ascontiguousarray(df[list(inputs)].to_numpy(dtype=np.float64))
    y = np.ascontiguousarray(df[list(outputs)].to_numpy(dtype=np.float64))
    return u, y


def _split(block: np.ndarray, inputs: Sequence[int], outputs: Sequence[int]) -> tuple[Any, Any]:
    return _columns(np.asarray(block), inputs, "inputs"), _columns(np.asarray(block), outputs, "outputs")


def _pair(u: Any, y: Any) -> tuple[Any, Any]:
    u, y = np.asarray(u), np.asarray(y)
    u = u.reshape(len(u), -1) if u.ndim == 1 else u
    y = y.reshape(len(y), -1) if y.ndim == 1 else y
    return _columns(u, range(u.shape[1]), "u"), _columns(y, range(y.shape[1]), "y")


def _index_list(cols: Any, name: str) -> list[Any]:
    if cols is None:
        raise LiftedError(f"{name} must name the columns (indices or names)")
    if isinstance(cols, (int, np.integer)):
        return list(range(int(cols)))
    return list(cols)


def _shards(data: Any, u: Any, y: Any, inputs: Any, outputs: Any) -> list[Any]:
    """The record as a list of delayed (u, y) shards, in record order."""
    delayed = _dask()
    if u is not None or y is not None:
        if u is None or y is None or data is not None:
            raise LiftedError("give either data= with inputs/outputs, or both u= and y=")
        da = _module("dask.array")
        u = da.asarray(u)
        y = da.asarray(y)
        if u.ndim == 1:
            u = u[:, None]
        if y.ndim == 1:
            y = y[:, None]
        if u.shape[0] != y.shape[0]:
            raise LiftedError(f"u has {u.shape[0]} samples, y {y.shape[0]}")
        u = u.rechunk({1: -1})
        y = y.rechunk({0: u.chunks[0], 1: -1})
        ub = u.to_delayed().ravel()
        yb = y.to_delayed().ravel()
        return [delayed(_pair)(a, b) for a, b in zip(ub, yb)]
    if data is None:
        raise LiftedError("no data: give data= (dask array, dask DataFrame or shard files) or u= and y=")
    if isinstance(data, (str, os.PathLike)):
        data = [data]
    if isinstance(data, (list, tuple)):
        if not data:
            raise LiftedError("the list of shard files is empty")
        paths = [os.fspath(p) for p in data]
        ins, outs = _index_list(inputs, "inputs"), _index_list(outputs, "outputs")
        for p in paths:
            if not p.endswith((".npy", ".parquet", ".pq")):
                raise LiftedError(f"shard {p!r}: only .npy and .parquet files are read")
        return [_FileShard(p, tuple(ins), tuple(outs)) for p in paths]
    # dask DataFrame (has .to_delayed and .columns) or dask array.
    if hasattr(data, "columns") and hasattr(data, "to_delayed"):
        ins, outs = _index_list(inputs, "inputs"), _index_list(outputs, "outputs")
        missing = [c for c in ins + outs if c not in data.columns]
        if missing:
            raise LiftedError(f"columns {missing} not in the data (columns: {list(data.columns)[:20]})")
        return [delayed(_frame)(part, ins, outs) for part in data.to_delayed()]
    if hasattr(data, "to_delayed") and hasattr(data, "chunks"):
        if data.ndim != 2:
            raise LiftedError(f"data must be 2-D (samples x columns), got {data.ndim} dimensions")
        ins, outs = _index_list(inputs, "inputs"), _index_list(outputs, "outputs")
        data = data.rechunk({1: -1})
        return [delayed(_split)(b, ins, outs) for b in data.to_delayed().ravel()]
    raise LiftedError(
        f"data of type {type(data).__name__}: expected a dask array, a dask DataFrame or a list of .npy/.parquet files"
    )


# ---------------------------------------------------------------- tasks


def _plan(shard: Any, past: int, future: int, remove_means: bool, rows: int) -> bytes:
    u, y = _rows_of(shard, 0, rows)
    return _lifted.partial_plan(u, y, past=past, future=future, remove_means=remove_means)


def _compress(plan: bytes, shard: Any, threads: int) -> bytes:
    npy = _npy_file(shard)
    if npy is not None:
        f, su, sy = npy
        return _lifted.partial_compress_npy(plan, f.path, list(f.inputs), list(f.outputs), list(su), list(sy),
                                            threads=threads)
    u, y = _data(shard)
    return _lifted.partial_compress(plan, u, y, threads=threads)


def _prime(state: bytes, shard: Any, rows: int) -> bytes:
    u, y = _rows_of(shard, 0, rows)
    return _lifted.regression_prime(state, u, y)


def _regression(state: bytes, shard: Any, advance: bool) -> bytes:
    npy = _npy_file(shard)
    if npy is not None:
        f, su, sy = npy
        return _lifted.regression_npy(state, f.path, list(f.inputs), list(f.outputs), list(su), list(sy),
                                      advance=advance)
    u, y = _data(shard)
    if advance:
        return _lifted.regression_advance(state, u, y)
    return _lifted.regression_scan(state, u, y)


def _advance(state: bytes, shard: Any) -> bytes:
    return _regression(state, shard, True)


def _scan(state: bytes, shard: Any) -> bytes:
    return _regression(state, shard, False)


def _scan_after_tail(primed: bytes, tail: list[tuple[Any, int, int]], shard: Any) -> bytes:
    """A shard's regression rows scanned from the primed stream advanced
    over only the samples ``tail`` before it (slices ``(shard, start,
    stop)`` of the shards before, at most the stream's memory): the
    recursions have forgotten anything earlier (``regression_memory``), so
    no chain through the record and one read of the shard."""
    state = primed
    for s, a, b in tail:
        u, y = _rows_of(s, a, b)
        state = _lifted.regression_advance(state, u, y)
    return _scan(state, shard)


def _tails(rows: list[int], memory: int) -> list[list[tuple[int, int, int]]]:
    """For each shard, the slices (shard index, start, stop) of the last
    ``memory`` samples before it, in record order."""
    out = []
    for k in range(len(rows)):
        need, tail = memory, []
        j = k - 1
        while need > 0 and j >= 0:
            take = min(need, rows[j])
            tail.append((j, rows[j] - take, rows[j]))
            need -= take
            j -= 1
        out.append(tail[::-1])
    return out


def _tree(items: list[Any], join: Callable[..., Any]) -> Any:
    """Adjacent pairs joined level by level (record order kept)."""
    delayed = _dask()
    while len(items) > 1:
        nxt = [delayed(join)(items[i], items[i + 1]) for i in range(0, len(items) - 1, 2)]
        if len(items) % 2:
            nxt.append(items[-1])
        items = nxt
    return items[0]


def _compress_shards(
    shards: list[Any], past: int, future: int, remove_means: bool, threads: int, plan_rows: int, client: Any
) -> bytes:
    delayed = _dask()
    (plan,) = _compute(client, delayed(_plan)(shards[0], past, future, remove_means, plan_rows))
    pieces = [delayed(_compress)(plan, s, threads) for s in shards]
    root = _tree(pieces, _lifted.partial_append)
    (records,) = _compute(client, delayed(_lifted.partial_close)(root))
    return bytes(records)


def compress_shards(
    data: Any = None,
    *,
    u: Any = None,
    y: Any = None,
    inputs: Any = None,
    outputs: Any = None,
    past: int = 10,
    future: int = 10,
    remove_means: bool = True,
    threads: int = 1,
    plan_rows: int = 65536,
    client: Any = None,
) -> bytes:
    """The merged compressed record (bytes) of a sharded record: the first
    pass of :func:`identify` alone (to keep, or to merge with other records'
    by ``lifted._lifted.partial_merge``)."""
    shards = _shards(data, u, y, inputs, outputs)
    return _compress_shards(shards, past, future, remove_means, threads, plan_rows, _client(client))


#: Largest record (bytes of its float64 samples, inputs and outputs) that
#: :func:`identify` gathers to the client to run :func:`lifted.identify`
#: itself: 16 MiB, the size up to which ``lifted identify`` selects the
#: structure on held-out blocks in memory (its ``SELECT_MAX_BYTES``) before
#: it streams. About 5e5 samples of a 2x2 loop.
IN_MEMORY_BYTES = 16 << 20

#: The options the sharded engine runs (the streamed route's structure).
_SHARDED_OPTIONS = frozenset(
    {"method", "order", "max_order", "horizon", "past", "future", "remove_means",
     "noise_model", "dt", "threads", "system", "refine"}
)


def _rows(shard: Any) -> int:
    """Samples of a shard, from the file's header where there is one."""
    if isinstance(shard, _FileShard):
        if shard.path.endswith(".npy"):
            return int(np.load(shard.path, mmap_mode="r").shape[0])
        pq = _module("pyarrow.parquet")
        return int(pq.ParquetFile(shard.path).metadata.num_rows)
    u, _ = _data(shard)
    return int(np.asarray(u).shape[0])


def _record_size(
    raw: list[Any], data: Any, u: Any, channels: int, client: Any
) -> tuple[int, int]:
    """Samples and float64 bytes of the sharded record: from the arrays'
    shapes when the data are dask arrays (no block computed for it), from
    the files' headers, else by a task per partition (a DataFrame)."""
    known = u if u is not None else data
    rows_known = getattr(known, "shape", (None,))[0] if hasattr(known, "chunks") else None
    if isinstance(rows_known, (int, np.integer)):
        n = int(rows_known)
    else:
        delayed = _dask()
        n = int(sum(_compute(client, *[delayed(_rows)(s) for s in raw])))
    return n, n * channels * 8


def _channels(data: Any, u: Any, y: Any, inputs: Any, outputs: Any) -> int:
    """Inputs plus outputs of the record (for its size)."""
    if u is not None and y is not None:
        width = [a.shape[1] if getattr(a, "ndim", 1) == 2 else 1 for a in (u, y)]
        return int(sum(width))
    return len(_index_list(inputs, "inputs")) + len(_index_list(outputs, "outputs"))


def identify(
    data: Any = None,
    *,
    u: Any = None,
    y: Any = None,
    inputs: Any = None,
    outputs: Any = None,
    engine: str = "auto",
    plan_rows: int = 65536,
    client: Any = None,
    **options: Any,
) -> SubspaceFit:
    """Identifies one record stored as shards, on a Dask cluster, by the
    plan of :func:`lifted.identify`.

    ``data``: a dask array (samples x columns; ``inputs``/``outputs`` column
    indices, or ``inputs=m`` for the first m columns), a dask DataFrame
    (``inputs``/``outputs`` column names), or a list of ``.npy`` (indices)
    / Parquet (names) files in record order; or ``u=``, ``y=`` dask arrays
    chunked along samples. ``options``: the keywords of
    :func:`lifted.identify` (``method``, ``order``, ``horizon``, ``refine``,
    ``selection``, ``budgets``, ``plan``, ``dt``, ...), with its defaults.

    ``engine``: ``"auto"`` (the default) gathers a record of up to
    :data:`IN_MEMORY_BYTES` to the client and runs :func:`lifted.identify`
    on it, so the model is that function's, bit for bit, whatever the
    options (held-out structure selection, Kalman-gain check, refinement,
    multirate records with NaN at the unmeasured samples, PBSID, ...);
    larger records run the sharded engine. ``"memory"`` always gathers,
    ``"sharded"`` never does. The sharded engine compresses each shard on its
    worker and merges the pieces (module docs): the single-rate N4SID /
    MOESP / CVA of the streamed route (``lifted identify`` on files too
    large for the held-out selection): horizon 10 (``horizon``, or
    ``past``/``future``), shift invariance, the order given or the
    singular-value gap up to ``max_order``, no Kalman-gain check and no
    refinement (they need the record in one process); any other option is
    refused naming it. Every channel is divided by its standard deviation
    over the record's first 1e4 samples as :func:`lifted.identify` does, and
    the model returned in the data's units. ``diagnostics["engine"]`` says
    which engine ran and why. Returns a :class:`lifted.SubspaceFit`.
    """
    if engine not in ("auto", "memory", "sharded"):
        raise LiftedError(f"engine must be 'auto', 'memory' or 'sharded', got {engine!r}")
    client = _client(client)
    delayed = _dask()
    raw = _shards(data, u, y, inputs, outputs)
    if engine != "sharded":
        n, nbytes = _record_size(raw, data, u, _channels(data, u, y, inputs, outputs), client)
        if engine == "memory" or nbytes <= IN_MEMORY_BYTES:
            from . import identify as _identify_mem

            parts = _compute(client, *[delayed(_data)(s) for s in raw])
            uu = np.vstack([np.asarray(p[0], dtype=np.float64).reshape(len(p[0]), -1) for p in parts])
            yy = np.vstack([np.asarray(p[1], dtype=np.float64).reshape(len(p[1]), -1) for p in parts])
            fit = _identify_mem(uu, yy, **options)
            why = "asked" if engine == "memory" else f"at most {IN_MEMORY_BYTES} bytes"
            fit.diagnostics.details["engine"] = (
                f"in memory: the record ({n} samples, {nbytes} bytes; {why}) gathered to the "
                "client and identified by lifted.identify with the options given"
            )
            return fit
    return _sharded(raw, options, plan_rows, client)


def _sharded(raw: list[Any], options: dict[str, Any], plan_rows: int, client: Any) -> SubspaceFit:
    """The sharded engine of :func:`identify` (module docs)."""
    delayed = _dask()
    other = sorted(set(options) - _SHARDED_OPTIONS)
    if other:
        raise LiftedError(
            f"{', '.join(other)}: not run by the sharded engine (records over {IN_MEMORY_BYTES} "
            "bytes, or engine='sharded'): it takes method, order, max_order, horizon (or past "
            "and future), remove_means, noise_model, dt and threads"
        )
    method = options.get("method", "n4sid")
    if options.get("system") not in (None, "shift"):
        raise LiftedError("system: the sharded engine estimates A by shift invariance only")
    if options.get("refine", "auto") not in ("auto", "none"):
        raise LiftedError("refine: the sharded engine cannot refine (the record is never in one process)")
    horizon = options.get("horizon")
    past = options.get("past", horizon if horizon is not None else 10)
    future = options.get("future", horizon if horizon is not None else 10)
    remove_means = options.get("remove_means", True)
    threads = options.get("threads", 1)
    dt = options.get("dt", 1.0)
    # Channels divided by their scales, as lifted.identify does; the model
    # comes back in the data's units.
    su, sy = _channel_scales(raw, client)
    shards = [
        _Scaled(s, tuple(su), tuple(sy))
        if isinstance(s, _FileShard)
        else delayed(_scale_pair)(s, tuple(su), tuple(sy))
        for s in raw
    ]
    records = _compress_shards(shards, past, future, remove_means, threads, plan_rows, client)
    first = _lifted.partial_identify(
        records,
        method=method,
        order=options.get("order"),
        max_order=options.get("max_order", 10),
        past=past,
        future=future,
        remove_means=remove_means,
        noise_model=options.get("noise_model", True),
        dt=dt,
        threads=threads,
    )
    second = "none (B, D from the compressed data)"
    if not first.wants_second_pass():
        fit = _subspace_fit(first.finish(input_scales=su, output_scales=sy))
    else:
        # Second pass, parallel: the regressor recursions' state goes from
        # shard to shard (cheap: filtering only), each shard's rows are
        # scanned from its state on its worker, and the R factors merge in
        # a tree.
        (start,) = _compute(client, delayed(_prime)(first.regression(), shards[0], plan_rows))
        pieces, second = _second_pass(start, shards, raw)
        merged = _tree(pieces, _lifted.regression_merge)
        final = delayed(_lifted.regression_end_record)(delayed(_lifted.regression_absorb)(start, merged))
        (final,) = _compute(client, final)
        fit = _subspace_fit(first.finish(final, input_scales=su, output_scales=sy))
    fit.diagnostics.details["engine"] = (
        f"sharded: merged partial compressions, horizon {past}/{future}, shift invariance, "
        "no Kalman-gain check and no refinement (they need the record in one process); "
        f"second pass: {second}"
    )
    return fit


def _second_pass(primed: bytes, shards: list[Any], raw: list[Any]) -> tuple[list[Any], str]:
    """The delayed regression pieces of every shard, and how they are
    scanned. When the regressor recursions forget their state within
    ``regression_memory`` samples and the shards are files (their lengths
    known from the headers), each shard is scanned from the primed state
    advanced over just the tail of samples before it: the tasks are
    independent and each reads its shard once (and the tail), unless the
    tails together are longer than the record (a pole near the unit
    circle), when re-reading each shard is cheaper. Otherwise the state
    goes from shard to shard (an advance task per shard, chained), each
    shard then read twice."""
    delayed = _dask()
    memory = _lifted.regression_memory(primed)
    files = all(isinstance(s, _FileShard) for s in raw)
    rows = [_rows(s) for s in raw] if files else []
    tails = _tails(rows, memory) if memory is not None else []
    # The tails' extra reading against the chain's second read of every shard.
    if files and memory is not None and sum(b - a for t in tails for _, a, b in t) <= sum(rows):
        pieces = [
            delayed(_scan_after_tail)(primed, [(shards[j], a, b) for j, a, b in tail], s)
            for s, tail in zip(shards, tails)
        ]
        return pieces, (
            f"each shard read once, scanned from the state after the {memory} samples before it "
            "(the regressor filters forget their start within them)"
        )
    state: Any = primed
    pieces = []
    for s in shards:
        pieces.append(delayed(_scan)(state, s))
        state = delayed(_advance)(state, s)
    if not files:
        why = "the shards are not files"
    elif memory is None:
        why = "A has a mode on the unit circle or ill-conditioned eigenvectors"
    else:
        why = f"the filters' memory of {memory} samples is longer than re-reading the shards"
    return pieces, f"the regressor state chained from shard to shard, each shard read twice ({why})"


# ---------------------------------------------------------------- many loops


@dataclass
class ManyResult:
    """What :func:`identify_many` returns: the models and the failures, by
    loop name (list positions when the loops came as a list)."""

    models: dict[Any, Any] = field(default_factory=dict)
    errors: dict[Any, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.models) + len(self.errors)


def _one(u: Any, y: Any, options: dict[str, Any]) -> tuple[str, Any]:
    from . import identify as _identify_mem

    try:
        return ("ok", _identify_mem(u, y, **options))
    except Exception as e:  # reported per loop, never raised
        return ("error", e)


def identify_many(
    loops: Mapping[Any, tuple[Any, Any]] | Iterable[tuple[Any, Any]],
    *,
    client: Any = None,
    **options: Any,
) -> ManyResult:
    """Identifies many independent loops, one task each.

    ``loops``: a mapping name -> (u, y) or a sequence of (u, y) (numpy
    arrays, or dask delayed objects / futures of them); ``options`` as for
    :func:`lifted.identify`. A loop whose identification fails is reported
    in ``errors`` with its exception (the others are kept).
    """
    client = _client(client)
    delayed = _dask()
    items = list(loops.items()) if isinstance(loops, Mapping) else list(enumerate(loops))
    tasks = []
    for name, pair in items:
        try:
            u, y = pair
        except (TypeError, ValueError):
            tasks.append((name, None))
            continue
        tasks.append((name, delayed(_one)(u, y, options)))
    out = ManyResult()
    live = [(n, t) for n, t in tasks if t is not None]
    for name, t in tasks:
        if t is None:
            out.errors[name] = LiftedError(f"loop {name!r}: expected a pair (u, y)")
    results = _compute(client, *[t for _, t in live]) if live else ()
    for (name, _), (status, value) in zip(live, results):
        if status == "ok":
            out.models[name] = value
        else:
            out.errors[name] = value
    return out
