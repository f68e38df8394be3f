"""pleat-render-export stack: the wardrobe sheet of scripts/demo.sh --garment a,b (a row per garment)."""
import matplotlib.image as mpimg
import numpy as np

from pleat.render_export import stack_images


def test_images_are_stacked_top_first_on_a_white_page_as_wide_as_the_widest(tmp_path):
    mpimg.imsave(tmp_path / "a.png", np.zeros((10, 20, 3)))
    mpimg.imsave(tmp_path / "b.png", np.full((5, 30, 3), 0.5))
    assert stack_images([tmp_path / "a.png", tmp_path / "b.png"], tmp_path / "s.png") == (15, 30, 3)
    page = mpimg.imread(tmp_path / "s.png")[..., :3]
    assert page.shape == (15, 30, 3)
    np.testing.assert_allclose(page[:10, :20], 0.0)           # the first image, top left
    np.testing.assert_allclose(page[:10, 20:], 1.0)           # white beside the narrower one
    np.testing.assert_allclose(page[10:], 0.5, atol=1 / 255)  # the second below it
