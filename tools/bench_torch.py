#!/usr/bin/env python3
"""The senc-model network in PyTorch (CPU), timed on the same graph as the Rust benchmark.

Usage:
    cargo xtask bench model --export /tmp/senc-bench      # or --torch, which runs this script
    python3 tools/bench_torch.py --graph /tmp/senc-bench/graph [--reps 3] [--threads 2] [--split]
        [--small 32,4,1] [--quick] [--json OUT.json]

Sizes, in the order `cargo xtask bench model` prints them: --small (latent, blocks, hidden
layers; default the t-shirt config's 32,4,1), HOOD with one block, full HOOD (latent 128,
15 blocks, 2 hidden layers; one rep with --quick).

Same architecture as crates/senc-model/src/network.rs: node and per-edge-type encoders,
message-passing blocks e' = e + MLP([e, h_r, h_s]) per edge type and
h' = h + MLP([h, sum e'_mesh, sum e'_body, sum e'_self]), decoder to 3 values for the cloth
nodes; MLPs in -> L -> (L -> L) x (hidden - 1) -> out with ReLU, LayerNorm on all but the
decoder. By default the edge MLP concatenates its inputs (the usual PyTorch / HOOD way);
--split uses the same split first layer as the Rust code. Features are random (timing only).
Prints median wall-clock times after one warm-up, as the Rust benchmark does.
"""
import argparse
import json
import os
import statistics
import time

import torch
from torch import nn


def mlp(d_in, latent, d_out, hidden, norm):
    layers = [nn.Linear(d_in, latent)]
    for _ in range(hidden - 1):
        layers += [nn.ReLU(), nn.Linear(latent, latent)]
    layers += [nn.ReLU(), nn.Linear(latent, d_out)]
    if norm:
        layers.append(nn.LayerNorm(d_out))
    return nn.Sequential(*layers)


class SplitMlp(nn.Module):
    """First layer applied part by part (no concatenation), then the rest of the MLP."""

    def __init__(self, parts, latent, d_out, hidden, norm):
        super().__init__()
        self.first = nn.ModuleList([nn.Linear(p, latent, bias=(k == 0)) for k, p in enumerate(parts)])
        full = mlp(sum(parts), latent, d_out, hidden, norm)
        self.rest = nn.Sequential(*list(full.children())[1:])


class Block(nn.Module):
    def __init__(self, latent, hidden, norm, split):
        super().__init__()
        self.split = split
        if split:
            self.edges = nn.ModuleList([SplitMlp([latent] * 3, latent, latent, hidden, norm) for _ in range(3)])
            self.node = SplitMlp([latent] * 4, latent, latent, hidden, norm)
        else:
            self.edges = nn.ModuleList([mlp(3 * latent, latent, latent, hidden, norm) for _ in range(3)])
            self.node = mlp(4 * latent, latent, latent, hidden, norm)

    def forward(self, h, es, graph):
        n = h.shape[0]
        aggs = []
        new_es = []
        for t, (e, (s, r)) in enumerate(zip(es, graph)):
            m = self.edges[t]
            if self.split:
                pre = m.first[0](e) + m.first[1](h)[r] + m.first[2](h)[s]
                e = e + m.rest(pre)
            else:
                e = e + m(torch.cat([e, h[r], h[s]], dim=1))
            new_es.append(e)
            aggs.append(torch.zeros_like(h).index_add_(0, r, e))
        if self.split:
            pre = self.node.first[0](h)
            for k, a in enumerate(aggs):
                pre = pre + self.node.first[1 + k](a)
            h = h + self.node.rest(pre)
        else:
            h = h + self.node(torch.cat([h] + aggs, dim=1))
        return h, new_es


class Net(nn.Module):
    def __init__(self, f_node, f_edge, latent, blocks, hidden, norm=True, split=False):
        super().__init__()
        self.node_enc = mlp(f_node, latent, latent, hidden, norm)
        self.edge_enc = nn.ModuleList([mlp(f_edge, latent, latent, hidden, norm) for _ in range(3)])
        self.blocks = nn.ModuleList([Block(latent, hidden, norm, split) for _ in range(blocks)])
        self.dec = mlp(latent, latent, 3, hidden, False)

    def forward(self, nodes, edge_feats, graph, n_cloth):
        h = self.node_enc(nodes)
        es = [enc(f) for enc, f in zip(self.edge_enc, edge_feats)]
        for b in self.blocks:
            h, es = b(h, es, graph)
        return self.dec(h[:n_cloth])


def median_time(reps, f):
    f()
    ts = []
    for _ in range(reps):
        t0 = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def read_u32(path):
    with open(path, "rb") as fh:
        data = bytearray(fh.read())
    return torch.frombuffer(data, dtype=torch.int32).to(torch.int64)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--graph", required=True, help="DIR/graph, DIR as given to cargo xtask bench model --export")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--split", action="store_true")
    ap.add_argument("--quick", action="store_true", help="full HOOD size with one rep only")
    ap.add_argument("--small", default="32,4,1", help="latent,blocks,hidden of the small size")
    ap.add_argument("--json", help="also write the times (seconds) to this JSON file")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    meta = json.load(open(args.graph + ".json"))
    n = meta["n_cloth"] + meta["n_body"]
    graph, feats = [], []
    for name in ["mesh", "body", "self"]:
        s = read_u32(f"{args.graph}.{name}.senders.u32")
        r = read_u32(f"{args.graph}.{name}.receivers.u32")
        graph.append((s, r))
        feats.append(torch.randn(len(s), meta["edge_features"]))
    nodes = torch.randn(n, meta["node_features"])
    print(f"torch {torch.__version__}, threads {torch.get_num_threads()}, "
          f"load {' '.join(open('/proc/loadavg').read().split()[:3])}")
    print(f"graph: {n} nodes, edges " + ", ".join(f"{k} {v}" for k, v in meta["edges"].items()))
    sl, sb, sh = (int(v) for v in args.small.split(","))
    configs = [
        (f"config ({sl}, {sb} blocks, {sh} hidden)", sl, sb, sh, args.reps),
        ("hood, 1 block (128, 2 hidden)", 128, 1, 2, args.reps),
        ("hood (128, 15 blocks, 2 hidden)", 128, 15, 2, 1 if args.quick else args.reps),
    ]
    form = "split" if args.split else "cat"
    rows = []
    for label, latent, blocks, hidden, reps in configs:
        net = Net(meta["node_features"], meta["edge_features"], latent, blocks, hidden, split=args.split)
        g = torch.rand(meta["n_cloth"], 3)

        def fwd():
            with torch.no_grad():
                net(nodes, feats, graph, meta["n_cloth"])

        def fwd_bwd():
            net.zero_grad(set_to_none=True)
            x = net(nodes, feats, graph, meta["n_cloth"])
            (x * g).sum().backward()

        tf = median_time(reps, fwd)
        tb = median_time(reps, fwd_bwd)
        rows.append({"label": label, "forward": tf, "forward_backward": tb})
        print(f"{label:36} [{form}] | forward {tf * 1e3:8.1f} ms | forward+backward {tb * 1e3:8.1f} ms")
    print(f"load at end: {' '.join(open('/proc/loadavg').read().split()[:3])}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"torch": torch.__version__, "threads": torch.get_num_threads(), "form": form, "rows": rows}, fh)


if __name__ == "__main__":
    main()
