"""lifted.dask on a LocalCluster of 2 worker processes on 127.0.0.1: one
record of 2e6 samples in 8 shard files identified across the workers equals
the one-process identification; 20 loops with one bad are 19 models and one
named error. (Sizes kept to what the assertions need, for CI time: 2e6
samples are 8 shards of 250 000, each far over the centring block of 65 536
and the slowest pole's memory, so every shard boundary and the
one-read-per-shard pass are exercised as at 1e7.) Skipped when dask[distributed] is not installed (CI installs it)."""

from __future__ import annotations

import os
import pathlib

import numpy as np
import pytest

import lifted

if os.environ.get("LIFTED_DASK_TESTS") == "require":
    import dask.distributed as distributed  # CI: must run, not skip
    import lifted.dask as lifted_dask
else:
    distributed = pytest.importorskip("dask.distributed")
    lifted_dask = pytest.importorskip("lifted.dask")


def plant() -> lifted.StateSpace:
    """2x2, order 4: poles 0.9, 0.5 and 0.8 e^{±0.6j}."""
    a = np.diag([0.9, 0.5, 0.0, 0.0])
    r, th = 0.8, 0.6
    a[2:, 2:] = [[r * np.cos(th), -r * np.sin(th)], [r * np.sin(th), r * np.cos(th)]]
    t = np.array([[2.0, 0.3, -0.2, 0.1], [0.1, 1.5, 0.4, 0.0], [0.0, 0.2, 1.8, -0.3], [0.3, 0.0, 0.1, 1.2]])
    ti = np.linalg.inv(t)
    b = t @ np.array([[1.0, 0.2], [-0.5, 1.0], [0.3, 0.7], [0.8, -0.4]])
    c = np.array([[1.0, 0.5, -0.3, 0.2], [0.0, 0.7, 0.4, -1.0]]) @ ti
    return lifted.StateSpace(t @ a @ ti, b, c, np.array([[0.1, 0.0], [0.0, 0.2]]), 1.0)


def record(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    u = np.where(rng.random((n, 2)) < 0.5, -1.0, 1.0) + 0.3
    y, _ = lifted.simulate(plant(), u)
    return u, y + 0.05 * rng.standard_normal(y.shape) + 2.0


def poles(fit: dict) -> np.ndarray:
    p = np.linalg.eigvals(np.asarray(fit["model"].A))
    return p[np.lexsort((p.imag, p.real))]


def freqresp(fit: dict, w: np.ndarray) -> np.ndarray:
    m = fit["model"]
    a, b, c, d = (np.asarray(x) for x in (m.A, m.B, m.C, m.D))
    n = a.shape[0]
    return np.array([c @ np.linalg.solve(np.exp(1j * wk) * np.eye(n) - a, b) + d for wk in w])


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_sharded_record_equals_one_process(client, tmp_path: pathlib.Path) -> None:
    n = 2_000_000
    u, y = record(n, 3)
    cuts = np.linspace(0, n, 9).astype(int)
    paths = []
    for k in range(8):
        p = tmp_path / f"hist-{k:03d}.npy"
        np.save(p, np.hstack([u[cuts[k] : cuts[k + 1]], y[cuts[k] : cuts[k + 1]]]))
        paths.append(p)
    options = dict(method="n4sid", order=4, past=10, future=10)
    dist = lifted_dask.identify(paths, inputs=[0, 1], outputs=[2, 3], client=client, **options)
    one = lifted.identify(u, y, **options, system="shift", refine="none")
    # Same data, same estimator: the compression differs only in the
    # summation order and the centring reference (first 65536 samples vs
    # the whole record), the regression only in its block boundaries, so
    # poles and frequency response agree to rounding amplified by the SVD
    # (1e-9 relative leaves margin over the ~1e-12 seen and fails on any
    # lost sample or boundary product: one missing shard moves them ~1e-4).
    np.testing.assert_allclose(poles(dist), poles(one), rtol=0, atol=1e-9)
    w = np.linspace(0.01, 3.1, 32)
    g1, g2 = freqresp(dist, w), freqresp(one, w)
    assert np.abs(g1 - g2).max() <= 1e-9 * np.abs(g2).max()
    np.testing.assert_allclose(dist["y0"], one["y0"], rtol=1e-9, atol=1e-9)
    # Issue 50: the second pass read each shard once (no chain).
    assert "each shard read once" in dist.diagnostics["engine"], dist.diagnostics["engine"]
    # And the model is the plant's.
    g0 = freqresp({"model": plant()}, w)
    assert np.abs(g1 - g0).max() < 0.01 * np.abs(g0).max()


def test_dask_array_input_agrees_with_files(client) -> None:
    import dask.array as da

    u, y = record(200_000, 5)
    du = da.from_array(u, chunks=(30_000, 2))
    dy = da.from_array(y, chunks=(50_000, 2))  # rechunked to u's chunks
    fit = lifted_dask.identify(u=du, y=dy, order=4, engine="sharded", client=client)
    # The sharded engine's structure (horizon 10, shift invariance) given
    # to the in-memory call, which would otherwise select its own.
    one = lifted.identify(u, y, order=4, horizon=10, system="shift", refine="none")
    np.testing.assert_allclose(poles(fit), poles(one), rtol=0, atol=1e-9)
    assert fit.diagnostics["engine"].startswith("sharded")
    assert "chained" in fit.diagnostics["engine"] and "not files" in fit.diagnostics["engine"]
    both = da.from_array(np.hstack([u, y]), chunks=(70_000, 4))
    fit2 = lifted_dask.identify(both, inputs=2, outputs=[2, 3], order=4, engine="sharded",
                                client=client)
    np.testing.assert_allclose(poles(fit2), poles(one), rtol=0, atol=1e-9)


def test_identify_many_keeps_the_good_loops_and_names_the_bad(client) -> None:
    loops = {}
    for k in range(20):
        u, y = record(3000, 100 + k)
        loops[f"loop{k:02d}"] = (u, y)
    bad_u, bad_y = loops["loop17"]
    bad_y = bad_y.copy()
    bad_y[100, 1] = np.nan
    loops["loop17"] = (bad_u, bad_y)
    out = lifted_dask.identify_many(loops, client=client, order=4)
    assert len(out.models) == 19 and list(out.errors) == ["loop17"]
    err = out.errors["loop17"]
    assert isinstance(err, lifted.LiftedError)
    assert "y" in str(err) and ("NaN" in str(err) or "finite" in str(err))
    assert all(poles(m).shape == (4,) for m in out.models.values())


def test_bad_shard_specification_is_named() -> None:
    with pytest.raises(lifted.LiftedError, match="only .npy and .parquet"):
        lifted_dask.identify(["a.csv"], inputs=[0], outputs=[1])
    with pytest.raises(lifted.LiftedError, match="inputs must name"):
        lifted_dask.identify(["a.npy"], outputs=[1])


def test_parquet_shards_and_dataframe(client, tmp_path: pathlib.Path) -> None:
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    import dask.dataframe as dd

    u, y = record(60_000, 9)
    frame = pd.DataFrame({"u1": u[:, 0], "u2": u[:, 1], "y1": y[:, 0], "y2": y[:, 1]})
    paths = []
    for k, part in enumerate(np.array_split(np.arange(len(frame)), 3)):
        p = tmp_path / f"part-{k}.parquet"
        # Row groups of 10k rows: a shard's tail is read from its last groups.
        frame.iloc[part].to_parquet(p, row_group_size=10_000)
        paths.append(p)
    one = lifted.identify(u, y, order=4, horizon=10, system="shift", refine="none")
    fit = lifted_dask.identify(paths, inputs=["u1", "u2"], outputs=["y1", "y2"], order=4,
                               engine="sharded", client=client)
    np.testing.assert_allclose(poles(fit), poles(one), rtol=0, atol=1e-9)
    assert "each shard read once" in fit.diagnostics["engine"]
    ddf = dd.from_pandas(frame, npartitions=4)
    fit2 = lifted_dask.identify(ddf, inputs=["u1", "u2"], outputs=["y1", "y2"], order=4,
                                engine="sharded", client=client)
    np.testing.assert_allclose(poles(fit2), poles(one), rtol=0, atol=1e-9)
    with pytest.raises(lifted.LiftedError, match="not in the data"):
        lifted_dask.identify(ddf, inputs=["u1", "nope"], outputs=["y1"], order=2, client=client)
    # At the defaults, the gathered record is lifted.identify's, bit for bit.
    same = lifted_dask.identify(paths, inputs=["u1", "u2"], outputs=["y1", "y2"], client=client)
    default = lifted.identify(u, y)
    np.testing.assert_array_equal(np.asarray(same.model.A), np.asarray(default.model.A))


def test_tails_of_the_shards_before() -> None:
    # Shards of 5, 3 and 10 samples, memory 4: the second starts after the
    # first's last 4, the third after 1 of the first and all of the second.
    assert lifted_dask._tails([5, 3, 10], 4) == [[], [(0, 1, 5)], [(0, 4, 5), (1, 0, 3)]]
    assert lifted_dask._tails([5, 3], 100) == [[], [(0, 0, 5)]]


def test_slow_poles_scan_from_long_tails_or_chain(client, tmp_path: pathlib.Path, monkeypatch) -> None:
    """A first-order plant with a slow pole: the filters' memory (the
    identified pole's ceil(ln 1e-30 / ln rho) + 1 samples) spans more than
    one shard; the tails reach back over several shards while they are
    shorter than re-reading the record, else the state is chained. The
    tails give the chained second pass's model (the state they start from
    differs by 1e-30 of it), and the poles are the one-process model's."""
    n = 200_000
    rng = np.random.default_rng(11)
    u = np.where(rng.random((n, 1)) < 0.5, -1.0, 1.0)
    for pole, way in ((0.999, "each shard read once"), (0.9995, "chained")):
        g = lifted.StateSpace(np.array([[pole]]), np.array([[0.05]]), np.array([[1.0]]),
                              np.array([[0.0]]), 1.0)
        y, _ = lifted.simulate(g, u)
        y = y + 0.01 * rng.standard_normal(y.shape)
        paths = []
        for k, part in enumerate(np.array_split(np.arange(n), 4)):
            p = tmp_path / f"slow-{pole}-{k}.npy"
            np.save(p, np.hstack([u[part], y[part]]))
            paths.append(p)
        shards = dict(inputs=[0], outputs=[1], order=1, engine="sharded", client=client)
        fit = lifted_dask.identify(paths, **shards)
        assert way in fit.diagnostics["engine"], fit.diagnostics["engine"]
        one = lifted.identify(u, y, order=1, horizon=10, system="shift", refine="none")
        np.testing.assert_allclose(poles(fit), poles(one), rtol=0, atol=1e-9)
        with monkeypatch.context() as m:
            m.setattr(lifted_dask._lifted, "regression_memory", lambda state: None)
            chained = lifted_dask.identify(paths, **shards)
        assert "chained" in chained.diagnostics["engine"]
        for k in ("A", "B", "D"):
            a, b = np.asarray(getattr(fit.model, k)), np.asarray(getattr(chained.model, k))
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)


def test_a_bad_sample_in_a_shard_is_named(client, tmp_path: pathlib.Path) -> None:
    u, y = record(80_000, 13)
    y[51_234, 1] = np.inf
    paths = []
    for k, part in enumerate(np.array_split(np.arange(len(u)), 2)):
        p = tmp_path / f"bad-{k}.npy"
        np.save(p, np.hstack([u[part], y[part]]))
        paths.append(p)
    with pytest.raises(lifted.LiftedError, match=r"bad-1\.npy.*11234|11234.*bad-1\.npy"):
        lifted_dask.identify(paths, inputs=[0, 1], outputs=[2, 3], order=4, engine="sharded",
                             client=client)


def same_model(a: lifted.SubspaceFit, b: lifted.SubspaceFit) -> None:
    for k in ("A", "B", "C", "D"):
        np.testing.assert_array_equal(np.asarray(getattr(a.model, k)), np.asarray(getattr(b.model, k)))
    np.testing.assert_array_equal(np.asarray(a.model.kalman_gain), np.asarray(b.model.kalman_gain))


def test_default_options_give_lifted_identify_s_model(client, tmp_path: pathlib.Path) -> None:
    """Issue 48, engines under one plan: with the DEFAULT options (and with
    any of lifted.identify's keywords) the shards of a record of up to
    IN_MEMORY_BYTES give lifted.identify's model bit for bit — N4SID with its
    held-out selection, gain check and refinement, PBSID, and a multirate
    record (NaN at the unmeasured samples); the sharded engine refuses the
    options it cannot run, naming them."""
    u, y = record(6000, 21)
    cuts = [0, 2500, 4000, 6000]
    paths = []
    for k in range(3):
        p = tmp_path / f"s-{k}.npy"
        np.save(p, np.hstack([u[cuts[k] : cuts[k + 1]], y[cuts[k] : cuts[k + 1]]]))
        paths.append(p)
    shards = dict(inputs=[0, 1], outputs=[2, 3], client=client)
    fit = lifted_dask.identify(paths, **shards)
    same_model(fit, lifted.identify(u, y))
    assert fit.diagnostics["engine"].startswith("in memory")
    # ... and the command line's on the concatenated shards (its default
    # route on the same samples), to 1e-9.
    from test_identify import cli

    out = tmp_path / "cli.json"
    args = [str(cli()), "identify", "--concat", "--columns", "u1,u2,y1,y2", "--inputs", "u1,u2",
            "--outputs", "y1,y2", "--ts", "1", "--out", str(out)]
    for p in paths:
        args += ["--data", str(p)]
    import json
    import subprocess

    subprocess.run(args, check=True, capture_output=True)
    made = lifted.StateSpace.from_json(out.read_text())
    for k in ("A", "B", "C", "D"):
        np.testing.assert_allclose(np.asarray(getattr(made, k)), np.asarray(getattr(fit.model, k)),
                                   rtol=0, atol=1e-9)
    assert json.loads(out.read_text())["diagnostics"]["route"] == fit.diagnostics.route
    same_model(lifted_dask.identify(paths, method="pbsid", **shards),
               lifted.identify(u, y, method="pbsid"))
    # Multirate: y1 measured every 3 samples, y2 every 5.
    ym = y.copy()
    ym[np.arange(len(ym)) % 3 != 0, 0] = np.nan
    ym[np.arange(len(ym)) % 5 != 0, 1] = np.nan
    import dask.array as da

    mr = lifted_dask.identify(u=da.from_array(u, chunks=(2000, 2)),
                              y=da.from_array(ym, chunks=(2000, 2)), order=4, client=client)
    same_model(mr, lifted.identify(u, ym, order=4))
    with pytest.raises(lifted.LiftedError, match="selection"):
        lifted_dask.identify(paths, engine="sharded", selection={"tolerance": 1.0}, **shards)
    with pytest.raises(lifted.LiftedError, match="refine"):
        lifted_dask.identify(paths, engine="sharded", refine="pem", **shards)
    with pytest.raises(lifted.LiftedError, match="engine"):
        lifted_dask.identify(paths, engine="gpu", **shards)
