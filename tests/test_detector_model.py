"""The three detectors' shapes, late fusion, the loss, NMS, configs and checkpoints."""

import numpy as np
import pytest
import torch
import yaml

from simgen.errors import UserError
from tests.support.detector import tiny_config
from train import cli as train_cli
from train.checkpoint import FORMAT, VERSION, Checkpoint, load_checkpoint, save_checkpoint
from train.config import load_config, parse_config
from train.data import Encoded, Sample, collate, encode_sample
from train.detector.fusion import LateFusion
from train.detector.losses import detection_loss
from train.detector.model import build_detector
from train.detector.nms import nms_bev
from train.detector.postprocess import postprocess


def _batch(config, model, samples=2):
    rng = np.random.default_rng(0)
    items: list[Encoded] = []
    for _ in range(samples):
        points = tuple(
            np.column_stack([rng.uniform([-16, -24, 0], [16, 8, 2], (500, 3)), rng.uniform(0, 1, 500)]).astype(
                np.float32
            )
            for _ in range(config.model.fusion.input_frames)
        )
        boxes = np.tile(np.array([1.0, -5.0, 0.9, 0.8, 0.6, 1.8, 0.3], np.float32), (1, 3, 1))
        sample = Sample("c", 2, points, boxes, np.ones((1, 3), bool), np.arange(1), np.zeros(1, bool))
        items.append(encode_sample(sample, config, model.head.assigner))
    rows, cols = config.data.grid_size
    return collate(items, config.model.fusion.canvases, rows * cols, model.head.assigner.collate)


@pytest.mark.parametrize("fusion, boxes", [("single", 1), ("early", 1), ("late", 3)])
def test_forward_loss_and_detections(fusion, boxes):
    config = tiny_config(fusion)
    model = build_detector(config)
    batch = _batch(config, model)
    anchors = len(model.head.anchors)
    out = model(batch)
    assert out.scores.shape == (2, anchors) and out.deltas.shape == (2, anchors, boxes, 7)
    assert out.direction.shape == (2, anchors, 2)
    terms = detection_loss(out, batch.targets, config.loss)
    assert torch.isfinite(terms.total) and len(terms.loc) == boxes
    terms.total.backward()
    assert all(p.grad is not None for p in model.parameters() if p.requires_grad)
    model.eval()
    with torch.no_grad():
        found = postprocess(model(batch), model.head.anchors, config)
    assert len(found) == 2 and found[0].boxes.shape[1:] == (boxes, 7)


def test_late_fusion_convolves_three_frames_into_one_without_temporal_padding():
    fusion = LateFusion((4, 6), frames=3)
    levels = [torch.randn(2 * 3, 4, 5, 5), torch.randn(2 * 3, 6, 5, 5)]
    assert fusion(levels, batch_size=2).shape == (2, 10, 5, 5)
    assert fusion.levels[0][0].kernel_size == (3, 3, 3) and fusion.levels[0][0].padding == (0, 1, 1)
    # Frame order matters: swapping t-2 and t changes the output (the kernel is not symmetric in time).
    swapped = [x.view(2, 3, *x.shape[1:]).flip(1).reshape(x.shape) for x in levels]
    fusion.eval()
    assert not torch.allclose(fusion(levels, 2), fusion(swapped, 2))


def test_nms_keeps_the_best_of_overlapping_boxes():
    boxes = np.array(
        [[0, 0, 1, 0.8, 0.6, 1.8, 0], [0.1, 0, 1, 0.8, 0.6, 1.8, 0], [3, 0, 1, 0.8, 0.6, 1.8, 0]], np.float32
    )
    scores = np.array([0.5, 0.9, 0.7], np.float32)
    assert nms_bev(boxes, scores, 0.2, 10).tolist() == [1, 2]
    assert nms_bev(boxes, scores, 0.2, 1).tolist() == [1]
    assert nms_bev(boxes[:0], scores[:0], 0.2, 10).tolist() == []


@pytest.mark.parametrize("threshold", [0.01, 0.2, 0.5])
def test_nms_decided_by_bounds_equals_greedy_on_every_exact_iou(threshold):
    """Clusters of candidates as a detector makes them (hundreds around a few players): the kept boxes equal
    those of the greedy pass over the full exact IoU matrix."""
    from train.geometry import bev_iou

    rng = np.random.default_rng(7)
    centres = rng.uniform(-10, 10, (12, 2))
    n = 300
    boxes = np.column_stack([centres[rng.integers(0, 12, n)] + rng.normal(0, 0.3, (n, 2)), rng.uniform(0.5, 1.2, n),
                             rng.uniform(0.5, 1.1, (n, 2)), rng.uniform(1.5, 1.9, n), rng.uniform(-np.pi, np.pi, n)])
    boxes, scores = boxes.astype(np.float32), rng.uniform(0, 1, n).astype(np.float32)
    order = np.argsort(-scores, kind="stable")
    overlaps = bev_iou(boxes[order], boxes[order]) > threshold
    kept = []
    for i in range(n):
        if not any(overlaps[k, i] for k in kept):
            kept.append(i)
    assert nms_bev(boxes, scores, threshold, n).tolist() == order[kept].tolist()
    assert nms_bev(boxes, scores, threshold, 5).tolist() == order[kept[:5]].tolist()


def test_configs_load_and_reject_bad_keys(tmp_path):
    for name in ("single", "early", "late"):
        config = load_config(f"train/configs/{name}.yaml")
        assert config.model.fusion.name == config.model.method == name
    raw = yaml.safe_load(open("train/configs/late.yaml"))
    raw["model"]["backbone_2d"]["colour"] = 3
    with pytest.raises(UserError, match=r"unknown key 'model.backbone_2d.colour'"):
        parse_config(raw)
    raw = yaml.safe_load(open("train/configs/late.yaml"))
    raw["model"]["fusion"]["name"] = "middle"
    with pytest.raises(UserError, match=r"'model.fusion': .*'single', 'early', 'late'"):
        parse_config(raw)
    raw = yaml.safe_load(open("train/configs/single.yaml"))
    raw["model"]["head"]["tracklet_boxes"] = 3
    with pytest.raises(UserError, match="single-frame model regresses 1 box"):
        parse_config(raw)
    raw["model"]["head"]["tracklet_boxes"], raw["data"]["pillar_size_m"] = 1, 0.3
    with pytest.raises(UserError, match="whole multiples"):
        parse_config(raw)
    with pytest.raises(UserError, match="no such config file"):
        load_config(tmp_path / "missing.yaml")


def test_checkpoint_round_trip_and_foreign_files(tmp_path):
    config = tiny_config("late")
    model = build_detector(config)
    path = tmp_path / "checkpoint.pt"
    save_checkpoint(path, Checkpoint(config, model.state_dict(), None, 7))
    loaded = load_checkpoint(path)
    assert loaded.config == config and loaded.iteration == 7
    assert all(torch.equal(loaded.model[k], v) for k, v in model.state_dict().items())
    assert [p.name for p in tmp_path.iterdir()] == ["checkpoint.pt"]  # no temporary left behind
    (tmp_path / "text.pt").write_text("hello")
    torch.save({"weights": torch.zeros(2)}, tmp_path / "other.pt")
    for name in ("text.pt", "other.pt", "missing.pt"):
        with pytest.raises(UserError) as error:
            load_checkpoint(tmp_path / name)
        assert "\n" not in str(error.value)


def test_an_old_config_or_checkpoint_with_fusion_none_still_loads_as_single(tmp_path, capsys):
    """`fusion: none`, the name before `single`: read as single with a one-line warning naming the file."""
    old = yaml.safe_load(open("train/configs/single.yaml"))
    old["model"]["fusion"]["name"] = "none"
    config_path = tmp_path / "old.yaml"
    config_path.write_text(yaml.safe_dump(old))
    with pytest.warns(FutureWarning, match=r"old.yaml: 'model.fusion.name: none' is deprecated, read as single"):
        assert load_config(config_path) == load_config("train/configs/single.yaml")

    config = tiny_config("single")
    model = build_detector(config)
    payload = {"format": FORMAT, "version": VERSION, "config": config.model_dump(mode="json"),
               "model": model.state_dict(), "optimizer": None, "iteration": 3}
    payload["config"]["model"]["fusion"]["name"] = "none"  # as simgen-train wrote it before the rename
    torch.save(payload, tmp_path / "old.pt")
    with pytest.warns(FutureWarning, match=r"old.pt \(config\): 'model.fusion.name: none' is deprecated"):
        loaded = load_checkpoint(tmp_path / "old.pt")
    assert loaded.config == config and loaded.iteration == 3
    build_detector(loaded.config).load_state_dict(loaded.model)  # the same weights fit

    # the CLI: the warning is one line, then the command goes on (here to its missing dataset)
    assert train_cli.main(["fit", str(config_path), "--dataset", str(tmp_path / "missing"),
                           "-o", str(tmp_path / "out")]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 2 and lines[0].startswith("simgen-train: warning: ") and "read as single" in lines[0]
    assert lines[1].startswith("simgen-train fit: error: ")


def test_every_part_name_a_config_allows_has_a_builder():
    from typing import get_args

    from train.config import Backbone2dConfig, BoxCoderConfig, DenseHeadConfig, PillarEncoderConfig
    from train.detector.registry import BACKBONES_2D, BOX_CODERS, FUSIONS, HEADS, PILLAR_ENCODERS

    def names(section) -> set[str]:
        return set(get_args(section.model_fields["name"].annotation))

    fusions = set(
        load_config("train/configs/late.yaml").model_json_schema()["$defs"]["ModelConfig"]["properties"]["fusion"][
            "discriminator"
        ]["mapping"]
    )
    assert fusions == set(FUSIONS.builders) == {"single", "early", "late"}
    assert names(PillarEncoderConfig) == set(PILLAR_ENCODERS.builders)
    assert names(Backbone2dConfig) == set(BACKBONES_2D.builders)
    assert names(DenseHeadConfig) == set(HEADS.builders)
    assert names(BoxCoderConfig) == set(BOX_CODERS.builders)


def test_the_detector_is_assembled_from_the_parts_its_config_names():
    late, single = build_detector(tiny_config("late")), build_detector(tiny_config("single"))
    assert isinstance(late.fusion, LateFusion) and not isinstance(single.fusion, LateFusion)
    assert late.pillar_encoder.linear.in_features == single.pillar_encoder.linear.in_features == 4 + 6
    assert build_detector(tiny_config("early")).pillar_encoder.linear.in_features == 5 + 6  # the time channel
    assert late.head.box.out_channels == 2 * 3 * 7 and single.head.box.out_channels == 2 * 1 * 7


@pytest.mark.parametrize("fusion", ["single", "late"])
def test_bf16_autocast_path_runs_on_cpu(fusion):
    """The CUDA training step's mixed precision (bfloat16 autocast, float32 loss) on CPU at tiny size."""
    from train.fit import autocast

    config = tiny_config(fusion)
    model = build_detector(config)
    batch = _batch(config, model)
    with autocast(torch.device("cpu"), "on"):
        out = model(batch)
    assert out.scores.dtype == torch.bfloat16
    terms = detection_loss(out.float(), batch.targets, config.loss)
    assert terms.total.dtype == torch.float32 and torch.isfinite(terms.total)
    terms.total.backward()
    assert all(p.grad is not None and p.grad.dtype == torch.float32 for p in model.parameters())
    with autocast(torch.device("cpu"), "auto"):  # auto: CUDA only
        assert model(batch).scores.dtype == torch.float32


def test_paper_configs_have_the_papers_sizes_and_train_at_tiny_range():
    for name in ("single", "early", "late"):
        config = load_config(f"train/configs/paper/{name}.yaml")
        model, backbone = config.model, config.model.backbone_2d
        assert model.fusion.name == name and model.pillar_encoder.channels == 64
        assert backbone.channels == (64, 128, 256) and backbone.strides[0] == 1 and backbone.output_stride == 1
        assert config.data.pillar_size_m * backbone.output_stride == 0.25 and len(model.head.anchor.yaws_rad) == 2
        assert config.train.bf16 == "auto" and config.train.workers > 1
    raw = load_config("train/configs/paper/late.yaml").model_dump(mode="json")
    raw["data"]["point_range_m"] = [-4.0, -4.0, -0.1, 4.0, 4.0, 2.5]  # 32 x 32 pillars
    config = parse_config(raw)
    model = build_detector(config)
    batch = _batch(config, model)
    from train.fit import autocast

    with autocast(torch.device("cpu"), "on"):
        out = model(batch)
    assert out.deltas.shape == (2, 32 * 32 * 2, 3, 7)
    detection_loss(out.float(), batch.targets, config.loss).total.backward()


def test_scaled_inputs_bring_every_decoration_to_unit_size():
    """`scale_inputs`: absolute x, y (tens of metres) no longer dwarf the pillar offsets (centimetres) and the time
    channel."""
    raw = tiny_config("early").model_dump(mode="json")
    raw["model"]["pillar_encoder"]["scale_inputs"] = True
    scaled, plain = (
        build_detector(parse_config(raw)).pillar_encoder,
        build_detector(tiny_config("early")).pillar_encoder,
    )
    seen = {}
    for name, encoder in (("scaled", scaled), ("plain", plain)):
        encoder.linear.register_forward_hook(lambda module, args, out, name=name: seen.update({name: args[0]}))
    rng = np.random.default_rng(3)
    points = np.column_stack([rng.uniform([-16, -24, -0.1], [16, 8, 2.5], (400, 3)), rng.uniform(0, 1, 400),
                              rng.integers(-2, 1, 400)]).astype(np.float32)
    from train.data import pillar_cells

    pillar, point_pillar = (
        torch.from_numpy(a) for a in np.unique(pillar_cells(points[:, :3], tiny_config("early")), return_inverse=True)
    )
    for encoder in (scaled, plain):
        encoder(torch.from_numpy(points), pillar, point_pillar, 1)
    span = seen["scaled"].abs().amax(dim=0)
    assert (span <= 2.0).all() and (span[8:10] >= 0.4).all(), span  # offsets from a 0.25 m pillar's centre: +-0.5
    assert seen["plain"].abs().amax(dim=0)[0] > 10 and seen["plain"].abs().amax(dim=0)[8] <= 0.125 + 1e-6


@pytest.mark.parametrize("stride, kernel", [(2, 3), (1, 3), (2, 1), (1, 1)])
def test_the_sparse_first_convolution_equals_the_dense_one(stride, kernel):
    """Pillars scattered into zeros and convolved, against the convolution from the pillars alone: the same
    values (to float32 rounding) and the same gradients for the pillars' features and the weights."""
    from train.detector.sparse_canvas import SparseCanvas, sparse_conv2d

    rng = np.random.default_rng(stride * 10 + kernel)
    canvases, rows, cols, channels = 3, 17, 12, 5
    index = torch.from_numpy(np.sort(rng.choice(canvases * rows * cols, 80, replace=False)))
    features = torch.from_numpy(rng.normal(size=(80, channels)).astype(np.float32)).requires_grad_()
    conv = torch.nn.Conv2d(channels, 4, kernel, stride, kernel // 2, bias=True)
    canvas = SparseCanvas(features, index, canvases, rows, cols)
    dense = conv(canvas.dense())
    sparse = sparse_conv2d(canvas, conv)
    assert sparse.shape == dense.shape
    torch.testing.assert_close(sparse, dense, rtol=1e-5, atol=1e-5)
    weights = torch.from_numpy(rng.normal(size=dense.shape).astype(np.float32))
    grads = [torch.autograd.grad((out * weights).sum(), (features, conv.weight, conv.bias)) for out in (dense, sparse)]
    for got, want in zip(grads[1], grads[0]):
        torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-4)


@pytest.mark.parametrize("fusion", ["single", "late"])
def test_channels_last_step_computes_what_the_default_layout_does(fusion):
    """train.channels_last (the GPU's fast layout; forced on here on CPU): the same scores, loss and gradients."""
    from train.accelerate import accelerate

    config = tiny_config(fusion)
    plain, fast = build_detector(config), build_detector(config)
    step = accelerate(fast, config.train.model_copy(update={"channels_last": "on"}), torch.device("cpu"))
    assert fast.backbone_2d.blocks[1][0].weight.is_contiguous(memory_format=torch.channels_last)
    batch = _batch(config, plain)
    outputs = []
    for model in (plain, step):
        out = model(batch)
        detection_loss(out.float(), batch.targets, config.loss).total.backward()
        outputs.append(out.scores)
    grads = [[p.grad for p in m.parameters()] for m in (plain, fast)]
    torch.testing.assert_close(outputs[1], outputs[0], rtol=1e-4, atol=1e-5)
    for fast_grad, plain_grad in zip(grads[1], grads[0]):  # to float32 summation order, against each tensor's scale
        torch.testing.assert_close(fast_grad, plain_grad, rtol=1e-3, atol=5e-3 * float(plain_grad.abs().max()))
    default = build_detector(config)
    assert accelerate(default, config.train, torch.device("cpu")) is default  # auto: CUDA only
    assert default.backbone_2d.blocks[1][0].weight.is_contiguous()


def test_compiled_bf16_step_has_the_eager_gradients():
    """train.compile under bf16 autocast (forced on here, on the CPU): the pillar encoder's max-pooling backward
    (scatter_reduce amax) finds its maxima again, so its gradients are finite and match the eager ones (the
    compiled step was NaN from its first step before train.accelerate asked Inductor to round as eager does)."""
    from train.accelerate import accelerate

    config = tiny_config("late")
    model = build_detector(config)
    batch = _batch(config, model)
    encoder = model.pillar_encoder
    step = accelerate(encoder, config.train.model_copy(update={"compile": "on"}), torch.device("cpu"))
    args = (batch.features, batch.pillar, batch.point_pillar, batch.batch_size * model.canvases)
    weights = torch.randn(len(batch.pillar), encoder.channels, generator=torch.Generator().manual_seed(0))
    grads = []
    for run in (encoder, step):
        with torch.autocast("cpu", dtype=torch.bfloat16):
            pooled = run(*args).features
        grads.append(torch.autograd.grad((pooled.float() * weights).sum(), list(encoder.parameters())))
    for got, want in zip(grads[1], grads[0]):
        assert torch.isfinite(got).all()
        torch.testing.assert_close(got, want, rtol=0.05, atol=0.05 * float(want.abs().max()))
