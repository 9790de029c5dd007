"""`LightField.cloud`: the point cloud `tiltfield cloud` writes, as numpy arrays, from the same
library function (jobs::cloud), and the same PLY file when a path is given."""

import json

import numpy as np
import pytest

import tiltfield


def test_the_cloud_is_the_clis_arrays_and_file(cli, planes, tmp_path):
    ours = tmp_path / "py.ply"
    theirs = tmp_path / "cli.ply"
    c = planes.cloud(ours, disparity=0.5, cameras=True, stride=2)
    r = cli.run("cloud", "builtin:planes", "-o", str(theirs), "--disparity", "0.5", "--cameras",
                "--stride", "2", "--json")
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    # The same file, byte for byte.
    assert ours.read_bytes() == theirs.read_bytes()
    n = c["points"]
    assert n == report["points"] and n > 0
    grid = planes.grid
    rows = n + 4 + grid[0] * grid[1]
    assert c["positions"].shape == (rows, 3) and c["positions"].dtype == np.float32
    assert c["normals"].shape == (rows, 3) and c["colours"].dtype == np.uint8
    assert c["quality"].shape == (rows,)
    assert c["faces"] == [[n, n + 1, n + 2, n + 3]]
    ((point, normal),) = c["planes"]
    assert np.allclose(point, report["plane"]["plane"]["point"])
    assert np.allclose(normal, report["plane"]["plane"]["normal"])
    # Cloud points lie in front of the cameras; fitted normals are unit vectors.
    assert np.all(c["positions"][:n, 2] > 0)
    fitted = np.linalg.norm(c["normals"][:n], axis=1)
    assert np.allclose(fitted[fitted > 0], 1.0, atol=1e-4)


def test_without_a_plane_there_is_no_quad(planes):
    c = planes.cloud()
    assert c["faces"] == [] and c["planes"] == []
    assert c["positions"].shape == (c["points"], 3)


@pytest.mark.parametrize(
    "kwargs, needle",
    [
        ({"stride": 0}, "stride"),
        ({"plane_size": -1.0}, "plane_size"),
        ({"path": "cloud.txt"}, "PLY"),
        ({"slab": 0.1}, "slab"),
    ],
)
def test_bad_cloud_requests_name_the_keyword(planes, kwargs, needle):
    with pytest.raises(ValueError) as e:
        planes.cloud(**kwargs)
    assert needle in str(e.value)
