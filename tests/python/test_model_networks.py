import torch

from emdm.model.discriminator import Discriminator
from emdm.model.generator import PRESETS, Generator, count_parameters
from emdm.model.layers import EluSELU


def test_selu_written_as_elu_equals_torch_selu():
    x = torch.linspace(-6, 6, 1001)
    torch.testing.assert_close(EluSELU()(x), torch.selu(x))


def test_generator_shapes_and_zero_output_in_padding():
    torch.manual_seed(0)
    G = Generator(16, "tiny").eval()
    x, mask = torch.randn(2, 30, 263), torch.ones(2, 30)
    mask[1, 20:] = 0
    y = G(x, torch.randn(2, 64), torch.randn(2, 16), torch.rand(2), mask)
    assert y.shape == (2, 30, 263)
    assert torch.all(y[1, 20:] == 0)


def test_padded_frames_do_not_change_the_real_frames():
    """A 20-frame motion padded to 50 gives the same x0 as the same motion alone (length-aware compute)."""
    torch.manual_seed(0)
    G = Generator(16, "tiny").eval()
    x, z, c, t = torch.randn(1, 20, 263), torch.randn(1, 64), torch.randn(1, 16), torch.tensor([0.4])
    alone = G(x, z, c, t, torch.ones(1, 20))
    padded_x = torch.cat([x, 100 * torch.randn(1, 30, 263)], dim=1)
    mask = torch.cat([torch.ones(1, 20), torch.zeros(1, 30)], dim=1)
    padded = G(padded_x, z, c, t, mask)
    torch.testing.assert_close(padded[:, :20], alone, atol=1e-5, rtol=1e-5)


def test_generator_uses_time_noise_and_condition():
    torch.manual_seed(0)
    G = Generator(16, "tiny").eval()
    x, z, c, t, m = torch.randn(1, 10, 263), torch.randn(1, 64), torch.randn(1, 16), torch.tensor([0.3]), torch.ones(1, 10)
    base = G(x, z, c, t, m)
    for changed in (G(x, torch.randn(1, 64), c, t, m), G(x, z, torch.zeros(1, 16), t, m), G(x, z, c, t + 0.5, m)):
        assert (changed - base).abs().max() > 1e-4


def test_presets_sizes():
    assert count_parameters(Generator(384, "web")) < 5_000_000            # fits a browser download
    assert PRESETS["paper"].d == 1024 and PRESETS["paper"].layers == 12 and PRESETS["paper"].heads == 32


def test_discriminator_conditional_and_unconditional():
    D = Discriminator(16, width=64)
    x, mask = torch.randn(3, 40, 263), torch.ones(3, 40)
    out = D(x, x, torch.randn(3, 16), torch.rand(3), torch.rand(3), mask)
    assert out.shape == (3,)
    Du = Discriminator(0, width=64)
    assert Du(x, x, torch.zeros(3, 0), torch.rand(3), torch.rand(3), mask).shape == (3,)
    # zero in padding: changing padded content does not change the logit
    mask[0, 30:] = 0
    x2 = x.clone()
    x2[0, 30:] += 5
    c, t, tp = torch.randn(3, 16), torch.rand(3), torch.rand(3)
    torch.testing.assert_close(D(x, x, c, t, tp, mask), D(x2, x2, c, t, tp, mask))


def test_discriminator_reads_its_input_at_every_width():
    # a GroupNorm group of one channel normalises to a constant: D must still see x (width 64 did not)
    for width in (64, 128, 1024):
        D = Discriminator(8, max_frames=20, width=width)
        x, mask = torch.randn(4, 20, 263), torch.ones(4, 20)
        c, t, tp = torch.randn(4, 8), torch.rand(4), torch.rand(4)
        a, b = D(x, x, c, t, tp, mask), D(x + torch.randn_like(x), x, c, t, tp, mask)
        assert (a - b).abs().max() > 1e-4, width
        assert a.std() > 1e-4, width
