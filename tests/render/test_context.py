"""Sheer's one standalone EGL context: the device it is made on (``SHEER_EGL_DEVICE``, the round robin)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pytest

from render.context import (
    ENV_DEVICE,
    SOFTWARE_EXTENSION,
    egl_devices,
    pinned_device,
    render_devices,
    round_robin_device,
    standalone_context,
)
from render.errors import RenderError

if TYPE_CHECKING:
    from collections.abc import Iterator, Sequence

GPU = "EGL_NV_device_cuda EGL_EXT_device_drm"
SOFTWARE = f"{SOFTWARE_EXTENSION} EGL_EXT_device_drm_render_node"


def _devices(gpus: int, software: bool = True) -> Sequence[str]:
    """A fake machine's EGL devices: ``gpus`` GPUs, then Mesa's software device."""
    return [GPU] * gpus + ([SOFTWARE] if software else [])


@pytest.fixture(autouse=True)
def _no_pin(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(ENV_DEVICE, raising=False)


def test_workers_take_the_gpus_round_robin_and_never_the_software_device_beside_them() -> None:
    four = _devices(4)
    assert render_devices(four) == [0, 1, 2, 3]
    assert [round_robin_device(i, four) for i in range(9)] == [0, 1, 2, 3, 0, 1, 2, 3, 0]
    two = [SOFTWARE, GPU, SOFTWARE, GPU]  # whatever order EGL lists them in: the indices are EGL's
    assert [round_robin_device(i, two) for i in range(4)] == [1, 3, 1, 3]


def test_one_device_to_share_or_no_index_is_the_default_device() -> None:
    assert round_robin_device(5, _devices(1)) is None  # one GPU and Mesa: one device, as before
    assert round_robin_device(3, _devices(0)) is None  # Mesa alone (this machine)
    assert round_robin_device(None, _devices(4)) is None  # a worker whose name gives no index
    assert round_robin_device(2, []) is None  # EGL cannot list its devices
    assert render_devices([SOFTWARE, SOFTWARE]) == [0, 1]  # only software devices: they are shared


def test_the_variable_pins_a_device_over_the_round_robin(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(ENV_DEVICE, "2")
    assert pinned_device(_devices(2)) == 2  # the software device, if one asks for it
    assert [round_robin_device(i, _devices(4)) for i in range(3)] == [2, 2, 2]
    monkeypatch.setenv(ENV_DEVICE, " ")
    assert pinned_device(_devices(2)) is None


@pytest.mark.parametrize(("value", "message"), [
    ("gpu1", r"^SHEER_EGL_DEVICE='gpu1' is not an integer: set it to an EGL device index \(this machine has "
             r"3 EGL devices \(0\.\.2\)\) or unset it$"),
    ("1.5", r"^SHEER_EGL_DEVICE='1\.5' is not an integer"),
    ("3", r"^SHEER_EGL_DEVICE=3 is out of range: this machine has 3 EGL devices \(0\.\.2\)$"),
    ("-1", r"^SHEER_EGL_DEVICE=-1 is out of range"),
])
def test_a_bad_value_is_one_line_naming_the_variable(monkeypatch: pytest.MonkeyPatch, value: str, message: str) -> None:
    monkeypatch.setenv(ENV_DEVICE, value)
    with pytest.raises(RenderError, match=message) as info:
        round_robin_device(0, _devices(2))
    assert "\n" not in str(info.value)


@pytest.fixture
def own_contexts(_gl_session_ctx: Any) -> Iterator[None]:
    """Make the session's context current again after a test made (and released) its own."""
    yield
    _gl_session_ctx.__enter__()  # a new context became current in this thread; the session's tests need theirs


@pytest.mark.gl
@pytest.mark.usefixtures("own_contexts")
def test_the_context_is_made_on_the_device_asked_for(monkeypatch: pytest.MonkeyPatch) -> None:
    devices = egl_devices()
    assert devices, "EGL lists no devices (EGL_EXT_device_enumeration)"
    ctx = standalone_context(device=len(devices) - 1)
    try:
        assert ctx.version_code >= 450
    finally:
        ctx.release()
    monkeypatch.setenv(ENV_DEVICE, "0")
    ctx = standalone_context(device=12345, require=330)  # pinned: the variable wins
    ctx.release()
    monkeypatch.setenv(ENV_DEVICE, str(len(devices)))
    with pytest.raises(RenderError, match=f"^{ENV_DEVICE}={len(devices)} is out of range"):
        standalone_context()
