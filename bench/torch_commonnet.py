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


class Disc(nn.Module):
    """The PatchGAN discriminator: c1 3->64 s2 lrelu 0.2; c2..c4 s2 + instance norm + lrelu 0.2; out
    512->1."""

    def __init__(self):
        super().__init__()
        ch = [3, 64, 128, 256, 512]
        self.c = nn.ModuleList(nn.Conv2d(ch[k], ch[k + 1], 3, stride=2, padding=1) for k in range(4))
        self.out = nn.Conv2d(512, 1, 3, padding=1)

    def forward(self, x):
        h = F.leaky_relu(self.c[0](x), 0.2)
        for k in range(1, 4):
            h = F.leaky_relu(F.instance_norm(self.c[k](h), eps=1e-5), 0.2)
        return self.out(h)


def sh_basis(n):
    """The 9 SH basis functions of normals n (B, 3, H, W) -> (B, 9, H, W)."""
    x, y, z = n[:, 0], n[:, 1], n[:, 2]
    return torch.stack([0.282095 * torch.ones_like(x), 0.488603 * y, 0.488603 * z, 0.488603 * x,
                        1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3 * z * z - 1),
                        1.092548 * x * z, 0.546274 * (x * x - y * y)], 1)


def fit_light(basis, s, m):
    """Per image: argmin_l sum_p m_p (basis_p . l - s_p)^2, detached (B, 9)."""
    B = basis.shape[0]
    A = (basis * m).reshape(B, 9, -1).transpose(1, 2)
    b = (s * m).reshape(B, -1, 1)
    return torch.linalg.lstsq(A, b).solution.reshape(B, 9).detach()


def shade(basis, l):
    return (basis * l[:, :, None, None]).sum(1, keepdim=True)


def best_of(fn, repeats):
    fn()  # warm-up
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def full_step(a, hd):
    """The median seconds of a whole training step on a.pairs pairs (see the file's comment)."""
    S, B = a.size, 2 * a.pairs
    disc = Disc()
    img = torch.rand(B, 3, S, S)
    yy, xx = torch.meshgrid(torch.linspace(-1, 1, S), torch.linspace(-1, 1, S), indexing="ij")
    mask = ((xx * xx + yy * yy) < 0.9).float()[None, None].expand(B, 1, S, S).contiguous()
    nbar = F.normalize(torch.randn(B, 3, S, S), dim=1)
    w = dict(rec=0.25, albedo=0.15, smooth=0.01, normal=0.5, light=0.01, srec=0.01, adv=0.0001, mean=1.0, prior=1.0)
    opt = torch.optim.Adam(hd.parameters(), lr=1e-4)
    dopt = torch.optim.Adam(disc.parameters(), lr=1e-4)
    msum = mask.sum((1, 2, 3))

    def mmean(x):  # the mean over the mask, per image, then over images
        return ((x * mask).sum((1, 2, 3)) / (msum * x.shape[1])).mean()

    def step():
        opt.zero_grad()
        albedo, shading, normal, light = hd(img)
        bbar = sh_basis(nbar)
        l_hat = fit_light(bbar, shading.detach(), mask)  # L_l's target
        prior_s = shade(bbar, fit_light(bbar, img.mean(1, keepdim=True), mask)).detach()  # the prior's
        s_nl = shade(sh_basis(normal), light)
        render = mask * albedo * s_nl
        dx, dy = shading[..., :, 1:] - shading[..., :, :-1], shading[..., 1:, :] - shading[..., :-1, :]
        loss = w["rec"] * mmean((img - albedo * shading).abs())
        loss = loss + w["albedo"] * (mask[0::2] * mask[1::2] * (albedo[0::2] - albedo[1::2]).abs()).mean()
        loss = loss + w["smooth"] * (torch.sqrt(dx[..., :-1, :] ** 2 + dy[..., :, :-1] ** 2 + 1e-6) * mask[..., 1:, 1:]).mean()
        loss = loss + w["normal"] * mmean(((nbar - normal) ** 2).sum(1, keepdim=True))
        loss = loss + w["light"] * (light - l_hat).abs().mean()
        loss = loss + w["srec"] * mmean((shading - s_nl).abs())
        loss = loss + w["adv"] * F.softplus(-disc(render)).mean()
        loss = loss + w["mean"] * ((shading * mask).sum((1, 2, 3)) / msum - 0.5).abs().mean()
        loss = loss + w["prior"] * mmean((shading - prior_s).abs())
        loss.backward()
        opt.step()
        # the discriminator: real m I against the detached render
        dopt.zero_grad()
        d_loss = F.softplus(-disc(mask * img)).mean() + F.softplus(disc(render.detach())).mean()
        d_loss.backward()
        dopt.step()

    step()  # warm-up
    times = []
    for _ in range(max(1, a.repeats // 2)):
        t = time.perf_counter()
        step()
        times.append(time.perf_counter() - t)
    times.sort()
    return times[len(times) // 2]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--width", type=int, default=48, help="Common-Net width of the training step")
    ap.add_argument("--pairs", type=int, default=1, help="pairs in the training step's batch")
    ap.add_argument("--step-only", action="store_true", help="only the training step")
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    torch.manual_seed(0)
    S = a.size
    r = {"torch": torch.__version__, "size": S, "threads": a.threads, "width": a.width, "pairs": a.pairs}
    if a.step_only:
        r["hdnet_train_step_pair_s"] = full_step(a, HDNet(a.width)) / a.pairs
        print(json.dumps(r) if a.json else f"PyTorch {r['torch']}, {a.threads} threads, {S}x{S}, width {a.width}, "
              f"{a.pairs} pairs: training step {r['hdnet_train_step_pair_s'] * 1e3:.1f} ms per pair "
              f"({r['hdnet_train_step_pair_s'] * a.pairs * 1e3:.1f} ms per step, median)")
        return

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

    r["hdnet_train_step_pair_s"] = full_step(a, hd if a.width == 48 else HDNet(a.width)) / a.pairs
    if a.json:
        print(json.dumps(r))
    else:
        print(f"PyTorch {r['torch']}, {a.threads} threads, {S}x{S}, best of {a.repeats}")
        print(f"  Common-Net (32->3, w 48) forward           {r['commonnet_fwd_s'] * 1e3:9.1f} ms")
        print(f"  Common-Net forward+backward                {r['commonnet_fwd_bwd_s'] * 1e3:9.1f} ms")
        print(f"  HD-Net forward, one image                  {r['hdnet_fwd_s'] * 1e3:9.1f} ms")
        print(f"  HD-Net training step (all terms, discriminator update), per pair, {a.pairs} pairs, width {a.width}: "
              f"{r['hdnet_train_step_pair_s'] * 1e3:.1f} ms (median)")


if __name__ == "__main__":
    main()
