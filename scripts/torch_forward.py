#!/usr/bin/env python3
"""StarNet's dense network in PyTorch from an export (`starnet export --out DIR`), checked on its golden vectors.

    pip install torch safetensors
    python3 scripts/torch_forward.py DIR

A reference for porting: `forward` below is the whole network in evaluation mode, built from model.safetensors
(PyTorch names and layouts) and model.json; it prints the largest difference to golden.safetensors.
"""
import json
import sys

import torch
from safetensors.torch import load_file

d = sys.argv[1]
sd, g, spec = load_file(f"{d}/model.safetensors"), load_file(f"{d}/golden.safetensors"), json.load(open(f"{d}/model.json"))
eps = spec["network"]["batch_norm_epsilon"]
def bn(x, p, m=None):
    y = (x - sd[p + ".running_mean"]) / torch.sqrt(sd[p + ".running_var"] + eps) * sd[p + ".weight"] + sd[p + ".bias"]
    return y if m is None else y * m
def lin(x, p):
    y = x @ sd[p + ".weight"].T
    return y + sd[p + ".bias"] if p + ".bias" in sd else y
pts, m = g["points"], g["mask"].unsqueeze(-1)
h = torch.relu(lin(pts, "featurizer.fc0")) * m
mean = lambda h: (h * m).sum(1) / m.sum(1).clamp(min=1)
read = [mean(h)]
for i in range(len(spec["network"]["blocks"])):
    p = f"featurizer.blocks.{i}"
    x = torch.cat([h, (h * m).amax(1, keepdim=True).expand_as(h)], -1)
    x = torch.relu(lin(bn(x, p + ".bn1", m), p + ".fc1"))
    h = torch.relu(lin(bn(x, p + ".bn2", m), p + ".fc2"))
    read.append(mean(h))
cell = bn(torch.cat(read, -1), "proj_bn")
x = torch.relu(lin(cell, "proj")).reshape(-1, spec["network"]["d_offset"])
c, a = len(pts), spec["anchors_per_center"]
cls = lin(x, "cls_head").reshape(c, a, -1)
box = lin(x, "box_head").reshape(c, a, 7)
if spec["network"].get("shared_size"):  # one size per center and anchor shape, the same at every offset
    size = lin(cell, "size_head").reshape(c, 1, -1, 3)
    box = box.reshape(c, -1, size.shape[2], 7)
    box = torch.cat([box[..., :3], size.expand(-1, box.shape[1], -1, -1), box[..., 6:]], -1).reshape(c, a, 7)
print("torch port vs golden: cls", float((cls - g["cls_logits"]).abs().max()), "box", float((box - g["box_residuals"]).abs().max()))
if spec.get("direction"):
    print("  dir", float((lin(x, "dir_head").reshape(c, a, 2) - g["dir_logits"]).abs().max()))
