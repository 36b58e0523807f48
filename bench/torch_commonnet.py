#!/usr/bin/python3
"""torch_commonnet.py: the side-by-side reference for docs/performance.md. The same Common-Net
(SPEC section 3) and HD-Net forward in PyTorch on the CPU, timed like `hdnet bench` (one warm-up,
then the best of --repeats runs):

  - Common-Net (cin 32, cout 3, width 48) forward and forward+backward at S x S, batch 1;
  - the whole HD-Net forward of one image (conv_in 3->32, a_net 32->3, s_net 32->1, n_net 1->3 on
    the detached shading, l_net on n_net's bottleneck);
  - a generator training step on one pair (2 images): forward, a loss touching every output,
    backward and an Adam step (the discriminator is left out).

Run: /usr/bin/python3 bench/torch_commonnet.py [--size 256] [--threads 2] [--repeats 5] [--json]
"""
import argparse
import json
import time

import torch
import torch.nn as nn
import torch.nn.functional as F


def lrelu(x):
    return F.leaky_relu(x, 0.1)


class CommonNet(nn.Module):
    """The Noise2Noise U-Net of SPEC section 3; forward returns (output, bottleneck)."""

    def __init__(self, cin, cout, w=48):
        super().__init__()
        c = lambda i, o: nn.Conv2d(i, o, 3, padding=1)
        self.enc0, self.enc1 = c(cin, w), c(w, w)
        self.enc2, self.enc3, self.enc4, self.enc5, self.enc6 = (c(w, w) for _ in range(5))
        self.dec5a, self.dec5b = c(2 * w, 2 * w), c(2 * w, 2 * w)
        self.dec4a, self.dec4b = c(3 * w, 2 * w), c(2 * w, 2 * w)
        self.dec3a, self.dec3b = c(3 * w, 2 * w), c(2 * w, 2 * w)
        self.dec2a, self.dec2b = c(3 * w, 2 * w), c(2 * w, 2 * w)
        self.dec1a, self.dec1b, self.dec1c = c(2 * w + cin, 64), c(64, 32), c(32, cout)

    def forward(self, x):
        p = F.max_pool2d
        up = lambda t: F.interpolate(t, scale_factor=2, mode="nearest")
        e = lrelu(self.enc1(lrelu(self.enc0(x))))
        p1 = p(e, 2)
        p2 = p(lrelu(self.enc2(p1)), 2)
        p3 = p(lrelu(self.enc3(p2)), 2)
        p4 = p(lrelu(self.enc4(p3)), 2)
        p5 = p(lrelu(self.enc5(p4)), 2)
        b = lrelu(self.enc6(p5))
        d = lrelu(self.dec5b(lrelu(self.dec5a(torch.cat([up(b), p4], 1)))))
        d = lrelu(self.dec4b(lrelu(self.dec4a(torch.cat([up(d), p3], 1)))))
        d = lrelu(self.dec3b(lrelu(self.dec3a(torch.cat([up(d), p2], 1)))))
        d = lrelu(self.dec2b(lrelu(self.dec2a(torch.cat([up(d), p1], 1)))))
        d = lrelu(self.dec1b(lrelu(self.dec1a(torch.cat([up(d), x], 1)))))
        return self.dec1c(d), b


class HDNet(nn.Module):
    """conv_in, ASD-Net (a_net, s_net), NLD-Net (n_net, l_net) of SPEC section 3."""

    def __init__(self, w=48):
        super().__init__()
        self.conv_in = nn.Conv2d(3, 32, 3, padding=1)
        self.a_net, self.s_net, self.n_net = CommonNet(32, 3, w), CommonNet(32, 1, w), CommonNet(1, 3, w)
        self.l_conv1 = nn.Conv2d(w, 64, 3, stride=2, padding=1)
        self.l_conv2 = nn.Conv2d(64, 64, 3, stride=2, padding=1)
        self.l_fc = nn.Linear(64, 9)

    def forward(self, img):
        f = self.conv_in(img)
        albedo = torch.sigmoid(self.a_net(f)[0])
        shading = F.softplus(self.s_net(f)[0])
        n, b = self.n_net(shading.detach())
        normal = F.normalize(torch.tanh(n), dim=1, eps=1e-6)
        h = lrelu(self.l_conv2(lrelu(self.l_conv1(b))))
        light = self.l_fc(h.mean(dim=(2, 3)))
        return albedo, shading, normal, light


def best_of(fn, repeats):
    fn()  # warm-up
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    torch.manual_seed(0)
    S = a.size
    r = {"torch": torch.__version__, "size": S, "threads": a.threads}

    net = CommonNet(32, 3)
    x = torch.randn(1, 32, S, S)
    with torch.no_grad():
        r["commonnet_fwd_s"] = best_of(lambda: net(x), a.repeats)

    def fwd_bwd():
        net.zero_grad()
        out, _ = net(x)
        out.sum().backward()

    r["commonnet_fwd_bwd_s"] = best_of(fwd_bwd, a.repeats)

    hd = HDNet()
    img = torch.rand(1, 3, S, S)
    with torch.no_grad():
        r["hdnet_fwd_s"] = best_of(lambda: hd(img), a.repeats)

    pair = torch.rand(2, 3, S, S)
    nbar = F.normalize(torch.randn(2, 3, S, S), dim=1)
    opt = torch.optim.Adam(hd.parameters(), lr=1e-3)

    def train_step():
        opt.zero_grad()
        albedo, shading, normal, light = hd(pair)
        loss = (pair - albedo * shading).abs().mean() + (albedo[0] - albedo[1]).abs().mean()
        loss = loss + ((normal - nbar) ** 2).sum(1).mean() + light.abs().mean()
        loss.backward()
        opt.step()

    r["hdnet_train_step_pair_s"] = best_of(train_step, max(1, a.repeats // 2))

    if a.json:
        print(json.dumps(r))
    else:
        print(f"PyTorch {r['torch']}, {a.threads} threads, {S}x{S}, best of {a.repeats}")
        print(f"  Common-Net (32->3, w 48) forward           {r['commonnet_fwd_s'] * 1e3:9.1f} ms")
        print(f"  Common-Net forward+backward                {r['commonnet_fwd_bwd_s'] * 1e3:9.1f} ms")
        print(f"  HD-Net forward, one image                  {r['hdnet_fwd_s'] * 1e3:9.1f} ms")
        print(f"  HD-Net generator training step, one pair   {r['hdnet_train_step_pair_s'] * 1e3:9.1f} ms")


if __name__ == "__main__":
    main()
