#!/usr/bin/env python3
"""StarNet's dense network in PyTorch from an export (`starnet export --out DIR`): checked on its golden
vectors, or timed as a training step (the PyTorch peer of `starnet train`'s step, issue #38).

    pip install torch safetensors
    python3 scripts/torch_forward.py DIR
    python3 scripts/torch_forward.py DIR --train [--device cuda] [--batch 2 8 32] [--steps 60] [--threads 16]

A reference for porting: `forward` below is the whole network, built from model.safetensors (PyTorch names and
layouts) and model.json; in evaluation mode it prints the largest difference to golden.safetensors.

`--train` times what one step of `starnet train` computes at the export's widths: the batch copied from the host,
the forward in training mode (BatchNorm over the real points' batch statistics; the running statistics are not
moved, a few element-wise operations that `starnet train` does), the loss (sigmoid focal, Huber on
location, dimension and sin(heading), the two-bin direction cross-entropy; dense weights over every anchor, as the
Rust loss), backward, the global-norm clip, Adam with L2 decay, the weight EMA and one read back to the host. The
batch is random (a quarter of the point slots padded, 1 % of the anchors foreground): the step's cost does not
depend on the values. It prints the median step time and frames/s (a frame = `--centers` neighbourhoods of
`--points` points, the quickstart's training budget by default) per batch size.
"""
import argparse
import json
import statistics
import time

import torch
from safetensors.torch import load_file


def masked_bn(x, sd, p, eps, m=None, train=False):
    """BatchNorm over the last axis: running statistics, or (train) the batch's over the real rows."""
    if train:
        w = torch.ones_like(x[..., :1]) if m is None else m
        n = w.sum().clamp(min=1)
        mean = (x * w).sum(tuple(range(x.dim() - 1))) / n
        var = (((x - mean) ** 2) * w).sum(tuple(range(x.dim() - 1))) / n
    else:
        mean, var = sd[p + ".running_mean"], sd[p + ".running_var"]
    y = (x - mean) / torch.sqrt(var + eps) * sd[p + ".weight"] + sd[p + ".bias"]
    return y if m is None else y * m


def lin(x, sd, p):
    y = x @ sd[p + ".weight"].T
    return y + sd[p + ".bias"] if p + ".bias" in sd else y


def forward(sd, spec, pts, mask, train=False):
    """Points `[N, P, F]` and mask `[N, P]` -> cls `[N, A, K]`, box `[N, A, 7]`, dir `[N, A, 2]` or None."""
    net = spec["network"]
    eps = net["batch_norm_epsilon"]
    m = mask.unsqueeze(-1)
    h = torch.relu(lin(pts, sd, "featurizer.fc0")) * m
    def mean(h):
        return (h * m).sum(1) / m.sum(1).clamp(min=1)
    read = [mean(h)]
    for i in range(len(net["blocks"])):
        p = f"featurizer.blocks.{i}"
        x = torch.cat([h, (h * m).amax(1, keepdim=True).expand_as(h)], -1)
        x = torch.relu(lin(masked_bn(x, sd, p + ".bn1", eps, m, train), sd, p + ".fc1"))
        h = torch.relu(lin(masked_bn(x, sd, p + ".bn2", eps, m, train), sd, p + ".fc2"))
        read.append(mean(h))
    cell = masked_bn(torch.cat(read, -1), sd, "proj_bn", eps, train=train)
    x = torch.relu(lin(cell, sd, "proj")).reshape(-1, net["d_offset"])
    c, a = len(pts), spec["anchors_per_center"]
    cls = lin(x, sd, "cls_head").reshape(c, a, -1)
    box = lin(x, sd, "box_head").reshape(c, a, 7)
    if net.get("shared_size"):  # one size per center and anchor shape, the same at every offset
        size = lin(cell, sd, "size_head").reshape(c, 1, -1, 3)
        box = box.reshape(c, -1, size.shape[2], 7)
        box = torch.cat([box[..., :3], size.expand(-1, box.shape[1], -1, -1), box[..., 6:]], -1).reshape(c, a, 7)
    direction = lin(x, sd, "dir_head").reshape(c, a, 2) if spec.get("direction") else None
    return cls, box, direction


def check_golden(d, sd, spec):
    g = load_file(f"{d}/golden.safetensors")
    cls, box, direction = forward(sd, spec, g["points"], g["mask"])
    print("torch port vs golden: cls", float((cls - g["cls_logits"]).abs().max()),
          "box", float((box - g["box_residuals"]).abs().max()))
    if direction is not None:
        print("  dir", float((direction - g["dir_logits"]).abs().max()))


def huber(x, delta=1 / 9):
    a = x.abs()
    return torch.where(a <= delta, 0.5 * x * x / delta, a - 0.5 * delta)


def loss(out, t, b, alpha=0.25, gamma=2.0):
    """The Rust loss's terms with the quickstart's weights (dimension 3.0), summed per frame."""
    cls, box, direction = out
    y = t["classes"]
    ce = torch.nn.functional.binary_cross_entropy_with_logits(cls, y, reduction="none")
    p = torch.sigmoid(cls)
    p_t = p * y + (1 - p) * (1 - y)
    focal = (ce * (1 - p_t) ** gamma * (alpha * y + (1 - alpha) * (1 - y))).sum(-1)
    diff = box - t["residuals"]
    w = t["reg_weight"]
    terms = [
        (focal * t["cls_weight"]).sum() / b,
        (huber(diff[..., :3]).sum(-1) * w).sum() / b,
        (huber(diff[..., 3:6]).sum(-1) * w).sum() / b * 3.0,
        (huber(torch.sin(diff[..., 6])) * w).sum() / b * 2.0,
    ]
    if direction is not None:
        d = direction[..., 1] - direction[..., 0]
        terms.append((torch.nn.functional.softplus(d) - d * t["direction"]).sum() / b * 0.2)
    return sum(terms), terms


def host_batch(spec, b, centers, points, gen):
    """One random batch on the host (pinned, so the copy to a GPU is one DMA), as `make_batch` builds it."""
    n, p, f = b * centers, points, spec["network"]["d_input"]
    a, k = spec["anchors_per_center"], len(spec["classes"])
    fg = (torch.rand(n, a, generator=gen) < 0.01).float()
    batch = {
        "points": torch.randn(n, p, f, generator=gen),
        "mask": (torch.rand(n, p, generator=gen) < 0.75).float(),
        "classes": fg.unsqueeze(-1).expand(n, a, k).contiguous(),
        "cls_weight": torch.ones(n, a),
        "reg_weight": fg,
        "residuals": torch.randn(n, a, 7, generator=gen) * 0.1,
        "direction": (torch.rand(n, a, generator=gen) < 0.5).float(),
    }
    return {key: v.pin_memory() if torch.cuda.is_available() else v for key, v in batch.items()}


def time_training(sd, spec, args, batch):
    device, steps, warmup = args.device, args.steps, args.warmup
    params = {k: v.to(device).requires_grad_(not k.endswith(("running_mean", "running_var"))) for k, v in sd.items()}
    trained = [v for v in params.values() if v.requires_grad]
    ema = [v.detach().clone() for v in trained]
    adam = torch.optim.Adam(trained, lr=2e-3, eps=1e-6, weight_decay=1e-4)
    gen = torch.Generator().manual_seed(0)
    batches = [host_batch(spec, batch, args.centers, args.points, gen) for _ in range(4)]
    times = []
    for step in range(warmup + steps):
        start = time.perf_counter()
        t = {k: v.to(device, non_blocking=True) for k, v in batches[step % len(batches)].items()}
        out = forward(params, spec, t["points"], t["mask"], train=True)
        out = tuple(o if o is None else o.reshape(batch, -1, *o.shape[1:]) for o in out)
        total, terms = loss(out, {k: v.reshape(batch, -1, *v.shape[1:]) for k, v in t.items()}, batch)
        adam.zero_grad(set_to_none=True)
        total.backward()
        norm = torch.nn.utils.clip_grad_norm_(trained, 5.0)
        adam.step()
        with torch.no_grad():
            torch._foreach_lerp_(ema, trained, 0.01)
        torch.stack([*[x.detach() for x in terms], norm]).cpu()  # the one read back
        if step >= warmup:
            times.append(time.perf_counter() - start)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("export")
    ap.add_argument("--train", action="store_true", help="time training steps instead of checking the golden vectors")
    ap.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    ap.add_argument("--batch", type=int, nargs="+", default=[2], help="frames per step (several: one timing each)")
    ap.add_argument("--centers", type=int, default=256, help="centers a frame (the quickstart trains 256)")
    ap.add_argument("--points", type=int, default=32, help="points a center (the quickstart trains 32)")
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--warmup", type=int, default=10)
    ap.add_argument("--threads", type=int, default=0, help="CPU threads (0: PyTorch's default)")
    args = ap.parse_args()
    sd = load_file(f"{args.export}/model.safetensors")
    spec = json.load(open(f"{args.export}/model.json"))
    if not args.train:
        check_golden(args.export, sd, spec)
        return
    if args.threads:
        torch.set_num_threads(args.threads)
    name = torch.cuda.get_device_name() if args.device.startswith("cuda") else f"cpu, {torch.get_num_threads()} threads"
    print(f"torch {torch.__version__} on {name}: {args.centers} centers x {args.points} points a frame")
    for b in args.batch:
        median = time_training(sd, spec, args, b)
        print(f"batch {b:3}: step {median * 1e3:7.2f} ms (median of {args.steps}), {b / median:8.1f} frames/s")


if __name__ == "__main__":
    main()
