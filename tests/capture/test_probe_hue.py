"""The flash's hue read from the probe's halo (capture.probe._flash_hue), on synthetic probes.

The hue is regressed along rays from the highlight, so an environment that is even along each ray
cancels whatever its colour and level. What does not cancel is the environment's own texture under the
halo: where it brightens or changes colour towards the highlight, that change is read as flash light.
With the bench's flash (bench.capture_synthetic.FLASH_RGB) the lobby behind yaw+30-s24-above
(tests/capture/test_out_of_sample.py) reads R −2.15 %, G +0.36 %, B +3.31 %, the night behind
shadow-above15-s40 R +3.07 %, G −0.57 %, B −4.09 %. Measured on those two probes:

- unquantised and unclipped: R −2.12 %, B +2.61 % and R +3.20 %, B −4.05 %: neither the sensor's 8 bits
  nor its clipping cause it;
- the environment at half and a quarter of its level: B +1.68 %, +0.68 % and B −1.68 %, −0.55 %: the
  error scales with the environment's level under the halo;
- the environment under the halo flattened to its mean there: within 0.23 %;
- regressed on the true halo itself (the drawn lobe's exact shape; the environment a constant or a plane
  over the halo): R −1.5 to −1.6 %, B +3.3 to +3.5 % and R −1.2 to −1.9 %, B +2.5 to +3.6 %; on its
  gradients (the environment's texture whitened): B +2.7 to +4.4 % and +18 to +22 %. Knowing the halo's
  shape does not remove it: one flash probe cannot tell the flash from the environment's texture under
  the halo;
- a second probe photographed without the flash at the same exposure, subtracted from the first: within
  0.15 % (the hue of the difference).

So analyse_probe takes that second photograph (``without_flash``; ``sheer capture --probe-without-flash``)
and reads the hue as the halo's sum in the difference (capture.probe._flash_hue_difference): the lobby
with :data:`FLASH` R +0.05 %, G −0.03 %, B +0.19 % (from one probe R −1.80 %, B +4.44 %).
"""

from __future__ import annotations

import numpy as np
import pytest

from bench.capture_synthetic import DIM_ROOM, as_photographed, env_mean_radiance, light_from_camera, read_env
from capture.camera import Camera
from capture.probe import (
    LUMINANCE,
    ProbeError,
    analyse_probe,
    flash_reflection,
    probe_environment,
    synthetic_probe,
)
from core.assets import find_asset

#: A coloured flash (linear RGB, luminance 1): warmer than the bench's.
FLASH = np.array([1.0, 0.9, 0.72]) / float(np.array([1.0, 0.9, 0.72]) @ LUMINANCE)


def _camera(yaw_deg: float) -> Camera:
    """The out-of-sample cases' camera turned ``yaw_deg`` about the head's vertical (only its rotation
    matters to the orthographic ball)."""
    target = np.array([0.0, 1.3, 0.0])
    yaw = np.radians(yaw_deg)
    eye = target + 45.0 * np.array([np.sin(yaw), 0.0, np.cos(yaw)])
    return Camera.looking_at(eye, target, np.array([0.0, 1.0, 0.0]), 6.4, 512, 512)


def _hue_error(image: np.ndarray, flash: np.ndarray, without_flash: np.ndarray | None = None) -> np.ndarray:
    """The probe's flash hue relative to ``flash``, per channel (0.01 = 1 %); ``without_flash``: the same
    probe photographed without the flash (analyse_probe's)."""
    return np.asarray(analyse_probe(image, without_flash=without_flash).flash_rgb / flash - 1.0)


@pytest.mark.parametrize("ambient", [(0.06, 0.04, 0.02), (0.02, 0.04, 0.08), (0.3, 0.2, 0.1)])
def test_flash_hue_over_an_even_coloured_room(ambient: tuple[float, float, float]) -> None:
    """An even room of any colour and level cancels: measured within 0.2 % (the halo's mean, the room
    not taken off, reads 10–36 % off)."""
    camera = _camera(0.0)
    env = np.broadcast_to(np.asarray(ambient), (64, 128, 3))
    image = as_photographed(synthetic_probe(env, camera.R, light_from_camera(camera, 6.0, -4.0), FLASH))
    assert np.all(np.abs(_hue_error(image, FLASH)) < 0.005)


def _lobby_room(flatten: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """yaw+30-s24-above's probe without the flash (the lobby as the ball reflects it, linear, unclipped;
    with ``flatten`` the environment flattened to its mean under the halo, where the halo is over 1.1 % of
    its peak, 3 σ) and the flash's reflection (:func:`capture.probe.flash_reflection`, the flash 8° above
    the lens), both (256, 256[, 3])."""
    camera = _camera(30.0)
    env = read_env(str(find_asset("environments/lobby.exr")))
    scale = DIM_ROOM / float(env_mean_radiance(env).mean())
    light = light_from_camera(camera, 8.0, 0.0)
    room = probe_environment(env, camera.R, 256, scale)
    if flatten:
        halo = flash_reflection(256, camera.R, light, core_gain=0.0, halo_gain=1.0) > np.exp(-0.5 * 3.0 ** 2)
        room[halo] = room[halo].mean(axis=0)
    return room, flash_reflection(256, camera.R, light)


def _lobby_probe(flatten: bool) -> np.ndarray:
    """yaw+30-s24-above's probe with :data:`FLASH` as photographed (see :func:`_lobby_room`)."""
    room, lobe = _lobby_room(flatten)
    return as_photographed(np.clip(room + lobe[..., None] * FLASH, 0.0, 1.0))


def test_the_environments_texture_under_the_halo_is_the_hue_error() -> None:
    """The lobby flattened under the halo: measured within 0.11 %."""
    assert np.all(np.abs(_hue_error(_lobby_probe(flatten=True), FLASH)) < 0.005)


def test_the_lobby_probes_hue_stays_within_its_measured_error() -> None:
    """One flash probe: measured R −1.80 %, G +0.23 %, B +4.44 %: the bound is the worst and half a point."""
    assert np.all(np.abs(_hue_error(_lobby_probe(flatten=False), FLASH)) < 0.049)


def test_the_lobby_probes_hue_within_half_a_percent_with_a_probe_without_the_flash() -> None:
    """The flash probe and the same ball without the flash: measured R +0.05 %, G −0.03 %, B +0.19 %."""
    room, _ = _lobby_room()
    without = as_photographed(np.clip(room, 0.0, 1.0))
    error = _hue_error(_lobby_probe(flatten=False), FLASH, without)
    assert np.all(np.abs(error) < 0.005), error


@pytest.mark.parametrize("wrong", ["size", "exposure", "flash"])
def test_a_probe_without_the_flash_that_does_not_match_is_refused(wrong: str) -> None:
    """Another size, or another exposure (the room a third or twice as bright) is a ProbeError naming the
    flash-less photograph (the room of the probes here reads 0.993–1.000 of the
    flash probe's: capture.probe.ROOM_RATIO_MIN/MAX)."""
    room, _ = _lobby_room()
    flash_probe = _lobby_probe(flatten=False)
    without = {"size": as_photographed(np.clip(room[:200], 0.0, 1.0)),
               "exposure": as_photographed(np.clip(room / 3.0, 0.0, 1.0)),
               "flash": as_photographed(np.clip(room * 2.0, 0.0, 1.0))}[wrong]
    with pytest.raises(ProbeError, match=r"^ball0\.png: .*(same camera and crop|same exposure)"):
        analyse_probe(flash_probe, source="ball.png", without_flash=without, without_flash_source="ball0.png")
