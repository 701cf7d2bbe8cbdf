"""``--scheduler``: the same points on a Dask distributed cluster (a small LocalCluster)."""
import pytest

from optdesign.problem.loader import problem_from_dict

from .conftest import small

distributed = pytest.importorskip("distributed")


def test_dask_cluster_gives_the_local_front(small_front, tmp_path):
    from optdesign.fronts import sweep
    problem = problem_from_dict(small(points=3), where="small.yaml")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        result = sweep(problem, tmp_path, scheduler=cluster.scheduler_address, progress=False)
    df = result.points
    assert len(df) == 3 and (df["status"] == "optimal").all()
    assert result.run["workers"] == "dask"
    # the ends are the same solves as the local run's
    local = small_front[0].points
    assert df.iloc[0]["delta"] == pytest.approx(local.iloc[0]["delta"], rel=1e-9)
    assert df.iloc[-1]["ratio"] == pytest.approx(local.iloc[-1]["ratio"], rel=1e-9)
    assert (tmp_path / "pareto.csv").exists()
