"""DINOv2 attention backend with a tiny random checkpoint written by the test."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from vggc_cp.errors import VggcError
from vggc_cp.vision import AttentionConfig, DistanceConfig, attention_maps, compute_distances_full
from vggc_cp.vision.dinov2 import DinoVisionTransformer, arch_from_state_dict, load_dinov2

TINY = dict(embed_dim=32, depth=2, num_heads=2, patch_size=14, pos_grid=4,
            num_register_tokens=0, mlp_hidden=64)


def tiny_model(seed: int = 0, **over) -> tuple[DinoVisionTransformer, dict]:
    torch.manual_seed(seed)
    arch = {**TINY, **over}
    model = DinoVisionTransformer(**arch)
    with torch.no_grad():
        for p in model.parameters():
            p.copy_(torch.randn_like(p) * 0.2)
    return model.eval(), arch


def write_checkpoint(path, seed: int = 0, bare: bool = False, **over):
    model, arch = tiny_model(seed, **over)
    obj = model.state_dict() if bare else {"arch": arch, "state_dict": model.state_dict()}
    torch.save(obj, path)
    return model, arch


def images(n: int = 5, size: int = 40, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (n, size, size, 3), dtype=np.uint8)


@pytest.mark.parametrize("registers", [0, 4])
def test_tiny_checkpoint_gives_maps(tmp_path, registers):
    path = tmp_path / "tiny.pth"
    model, _ = write_checkpoint(path, num_register_tokens=registers)
    maps = attention_maps(images(), "dinov2", AttentionConfig(grid=3, weights=str(path)))
    assert maps.shape == (5, 9)
    assert np.all(maps > 0)
    np.testing.assert_allclose(maps.sum(1), 1.0)
    # recomputed attention is the one the fused kernel applies: softmax(q k^T / sqrt d) @ v
    x = torch.randn(2, 3, 42, 42)
    with torch.no_grad():
        t = model.prepare_tokens(x)
        assert t.shape == (2, 1 + registers + 9, 32)
        attn = model.blocks[0].attn
        y = model.blocks[0].norm1(t)
        _, _, v = attn.qk(y)
        manual = (attn.attention_weights(y) @ v).transpose(1, 2).reshape(2, -1, 32)
        np.testing.assert_allclose(attn.proj(manual).numpy(), attn(y).numpy(), atol=1e-5)
        cls = model.cls_attention(x)
        assert cls.shape == (2, 3, 3)
        assert torch.all(cls.sum((1, 2)) <= 1 + 1e-6)


def test_official_layout_loads_without_arch(tmp_path):
    path = tmp_path / "bare.pth"
    model, _ = write_checkpoint(path, bare=True, embed_dim=64, num_heads=1, depth=1,
                                num_register_tokens=4, mlp_hidden=256)
    sd = torch.load(path, weights_only=True)
    arch = arch_from_state_dict(sd)
    assert arch == {"embed_dim": 64, "depth": 1, "num_heads": 1, "patch_size": 14,
                    "pos_grid": 4, "num_register_tokens": 4, "mlp_hidden": 256,
                    "ffn_layer": "mlp"}
    loaded, arch2 = load_dinov2(path)
    assert arch2 == arch
    x = torch.randn(1, 3, 28, 28)
    with torch.no_grad():
        np.testing.assert_allclose(loaded.cls_attention(x).numpy(),
                                   model.cls_attention(x).numpy(), atol=1e-6)
        assert loaded.forward_features(x)["x_norm_clstoken"].shape == (1, 64)


def test_missing_weights_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.delenv("VGGC_CP_DINOV2_WEIGHTS", raising=False)
    with pytest.raises(VggcError, match="--weights"):
        attention_maps(images(1), "dinov2", AttentionConfig(grid=2))
    with pytest.raises(VggcError, match="no such file"):
        attention_maps(images(1), "dinov2", AttentionConfig(grid=2,
                                                            weights=str(tmp_path / "no.pth")))
    junk = tmp_path / "junk.pth"
    junk.write_bytes(b"not a checkpoint")
    with pytest.raises(VggcError, match="unreadable"):
        attention_maps(images(1), "dinov2", AttentionConfig(grid=2, weights=str(junk)))


def test_env_weights_and_cache_key_follow_the_file(tmp_path, monkeypatch):
    from test_vision_distances import scene_trace

    path = tmp_path / "tiny.pth"
    write_checkpoint(path, seed=0)
    monkeypatch.setenv("VGGC_CP_DINOV2_WEIGHTS", str(path))
    trace = scene_trace()
    cfg = DistanceConfig(backend="dinov2", grid=3, threads=1)
    a = compute_distances_full(trace, cfg, cache_dir=tmp_path / "c", progress=False)
    assert not a.cached and a.dist_pick.shape[0] > 1
    assert compute_distances_full(trace, cfg, cache_dir=tmp_path / "c", progress=False).cached
    write_checkpoint(path, seed=1)  # same path, other weights: the cache must not be reused
    b = compute_distances_full(trace, cfg, cache_dir=tmp_path / "c", progress=False)
    assert not b.cached and b.path != a.path
