"""The runtime's control API against a running ``sim`` session: state, the token, the
E-stop anyone may send, the control actions logged. References: the supervisor's rules
(arming, E-stop latched) and the API's documented contract."""

from __future__ import annotations

import json
import socket
import threading
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("starlette", reason="starlette (exoleg[api])")
httpx = pytest.importorskip("httpx", reason="httpx (exoleg[dev])")

from exoleg.runtime.control_api import ControlAPI  # noqa: E402
from exoleg.runtime.log import read_log  # noqa: E402
from exoleg.runtime.session import run  # noqa: E402


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait(url: str, key: str, want: object, timeout: float = 20.0) -> dict:
    deadline = time.time() + timeout
    state: dict = {}
    while time.time() < deadline:
        try:
            state = httpx.get(url, timeout=1.0).json()
        except httpx.HTTPError:
            state = {}
        if state.get(key) == want:
            return state
        time.sleep(0.05)
    raise AssertionError(f"{key} never became {want!r}: {state}")


def test_control_api_arms_refuses_without_token_and_estops(tmp_path: Path) -> None:
    port = _free_port()
    api = ControlAPI(tmp_path)
    result: dict = {}
    def session() -> None:
        result["res"], result["path"] = run("sim", 8.0, tmp_path, realtime=False, api=api,
                                            api_port=port)

    t = threading.Thread(target=session)
    t.start()
    base = f"http://127.0.0.1:{port}"
    _wait(f"{base}/state", "mode", 0)  # running, disarmed
    r = httpx.post(f"{base}/command", json={"command": "arm"})
    assert r.status_code == 401  # a control action without the token is refused
    r = httpx.post(f"{base}/command", json={"command": "jump"},
                   headers={"Authorization": f"Bearer {api.token}"})
    assert r.status_code == 400 and "allowed" in r.json()["error"]
    r = httpx.post(f"{base}/command", json={"command": "arm"},
                   headers={"Authorization": f"Bearer {api.token}"})
    assert r.status_code == 200
    _wait(f"{base}/state", "mode", 1)  # standing
    r = httpx.post(f"{base}/command", json={"command": "estop"})  # anyone may stop it
    assert r.status_code == 200
    state = _wait(f"{base}/state", "mode", 3)  # fault, latched
    t.join(timeout=60)
    assert state["tau"] == [0.0, 0.0, 0.0]
    _, cols, _ = read_log(result["path"])
    k = int(np.argmax(cols["mode"] == 3))
    for j in ("hip", "knee", "ankle"):
        assert np.all(cols[f"u_{j}"][k:] == 0.0)  # torque off from the E-stop's tick on
    actions = [json.loads(x) for x in (tmp_path / "control.log").read_text().splitlines()]
    assert [(a["command"], a["accepted"]) for a in actions] == [
        ("arm", False), ("jump", False), ("arm", True), ("estop", True)]
    assert all(a["source"] == "127.0.0.1" and a["time"] > 0 for a in actions)


def test_gains_within_bounds_only(tmp_path: Path) -> None:
    port = _free_port()
    api = ControlAPI(tmp_path)
    t = threading.Thread(target=lambda: run("sim", 4.0, tmp_path, realtime=False, api=api,
                                            api_port=port))
    t.start()
    base = f"http://127.0.0.1:{port}"
    _wait(f"{base}/state", "mode", 0)
    g = httpx.get(f"{base}/gains").json()
    kp = g["gains"]["kp_swing"]
    assert g["bounds"]["kp_swing"][2] == [0.0, 2 * kp[2]]  # shown with the gains
    auth = {"Authorization": f"Bearer {api.token}"}
    assert httpx.post(f"{base}/gains", json={"kp_swing": [1, 2, 3]}).status_code == 401
    r = httpx.post(f"{base}/gains", json={"kp_swing": [kp[0], kp[1], 3 * kp[2]]},
                   headers=auth)
    assert r.status_code == 422 and "kp_swing[2]" in r.json()["error"]
    r = httpx.post(f"{base}/gains", json={"support": 1.5}, headers=auth)
    assert r.status_code == 422 and "outside 0-1" in r.json()["error"]
    r = httpx.post(f"{base}/gains", json={"kp_swing": [kp[0], kp[1], 1.5 * kp[2]],
                                          "support": 0.5}, headers=auth)
    assert r.status_code == 200
    deadline = time.time() + 10
    while time.time() < deadline:
        now = httpx.get(f"{base}/gains").json()["gains"]
        if now["support"] == [0.5]:
            break
        time.sleep(0.05)
    assert now["kp_swing"][2] == pytest.approx(1.5 * kp[2]) and now["support"] == [0.5]
    t.join(timeout=60)
