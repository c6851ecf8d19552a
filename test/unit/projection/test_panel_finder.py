"""
find_panel on synthetic screenshots of an RViz2 window.

Each screenshot is drawn here with Pillow the way RViz2 looks on a desktop:
a window frame whose title bar has RViz's own background colour (GNOME's dark
header bar is #303030), a menu bar, a tool bar, docks with text, the two
16 px hide-dock buttons, a time panel, and the render panel cleared to
(48, 48, 48) with grid lines and markers drawn over it.  The panel's true
place and size are what the drawing used.
"""

import os

import numpy as np
from PIL import Image, ImageDraw
import pytest
import yaml

from eye_bci_ros2.projection.panel_finder import find_panel, NoPanelError, RVIZ_BACKGROUND, scaled
from eye_bci_ros2.tools import find_panel as cli

DESKTOP = (23, 60, 92)
LIGHT = {'frame': (246, 245, 244), 'dock': (239, 239, 239), 'button': (209, 209, 209),
         'text': (40, 40, 40)}
#: A dark Qt theme: its window colour (53, 53, 53) is 5 away from RViz's background.
DARK = {'frame': (53, 53, 53), 'dock': (53, 53, 53), 'button': (60, 60, 60),
        'text': (220, 220, 220)}


def rviz_screenshot(screen=(1920, 1080), panel=(336, 150, 1280, 720), scale=1, theme=None,
                    grid='perspective', markers=True, title_colour=RVIZ_BACKGROUND,
                    rng_seed=0) -> np.ndarray:
    """
    Draw a screen with an RViz2 window whose render panel is ``panel`` (x, y, w, h).

    ``panel`` and ``screen`` are logical px; the image is ``scale`` times
    larger (a HiDPI screen captured in device pixels).
    """
    theme = theme or LIGHT
    s = scale
    rng = np.random.default_rng(rng_seed)
    image = Image.new('RGB', (screen[0] * s, screen[1] * s), DESKTOP)
    draw = ImageDraw.Draw(image)
    x, y, w, h = panel
    left_dock, right_dock, button, bottom = 280, 240, 16, 60
    menu, tools, title = 24, 32, 37
    win = (x - button - left_dock, y - tools - menu - title,
           x + w + button + right_dock, y + h + bottom)

    def box(x0, y0, x1, y1, colour):
        draw.rectangle([x0 * s, y0 * s, x1 * s - 1, y1 * s - 1], fill=colour)

    box(*win, theme['frame'])
    box(win[0], win[1], win[2], win[1] + title, title_colour)
    box(win[0], y - tools, win[2], y, theme['dock'])
    box(win[0], y, x - button, y + h + bottom, theme['dock'])
    box(x - button, y, x, y + h, theme['button'])
    box(x + w, y, x + w + button, y + h, theme['button'])
    box(x + w + button, y, win[2], y + h + bottom, theme['dock'])
    for row in range(8):   # dock text lines
        for x0 in (win[0] + 10, x + w + button + 10):
            box(x0, y + 12 + 22 * row, x0 + int(rng.integers(60, 200)), y + 22 + 22 * row,
                theme['text'])
    box(x, y, x + w, y + h, RVIZ_BACKGROUND)
    grid_colour = (160, 160, 164)
    if grid == 'perspective':
        horizon, centre = y + 0.25 * h, x + 0.5 * w
        for k in range(-10, 11):
            draw.line([((centre + 40 * k) * s, horizon * s),
                       ((centre + 260 * k) * s, (y + h - 1) * s)], fill=grid_colour, width=s)
        for k in range(1, 9):
            row = horizon + (y + h - horizon) * (k / 8) ** 1.6
            draw.line([(x * s, row * s), ((x + w - 1) * s, row * s)], fill=grid_colour,
                      width=s)
    elif grid == 'ortho':   # TopDownOrtho: the grid is axis-aligned, whole rows and columns
        for u in range(x + 7, x + w, 64):
            draw.line([(u * s, y * s), (u * s, (y + h) * s - 1)], fill=grid_colour, width=s)
        for v in range(y + 5, y + h, 64):
            draw.line([(x * s, v * s), ((x + w) * s - 1, v * s)], fill=grid_colour, width=s)
    if markers:
        for (u, v, size, colour) in [(0.5, 0.5, 300, (200, 60, 60)),
                                     (0.2, 0.3, 120, (60, 200, 60)),
                                     (0.8, 0.7, 160, (60, 60, 200)),
                                     (0.35, 0.8, 90, (220, 220, 40))]:
            cu, cv, size = x + u * w, y + v * h, min(size, 0.7 * h)
            draw.polygon([((cu - size / 2) * s, cv * s), (cu * s, (cv - size / 2) * s),
                          ((cu + size / 2) * s, cv * s), (cu * s, (cv + size / 2) * s)],
                         fill=colour)
        box(x + w // 2 - 150, y + h // 2 - 40, x + w // 2 + 150, y + h // 2 + 40, (90, 90, 90))
    return np.asarray(image)


def as_tuple(panel):
    return (panel.x, panel.y, panel.width, panel.height)


@pytest.mark.parametrize('grid', ['perspective', 'ortho', None])
@pytest.mark.parametrize('theme', [LIGHT, DARK], ids=['light', 'dark'])
def test_panel_found_exactly_through_frame_docks_grid_and_markers(grid, theme):
    image = rviz_screenshot(grid=grid, theme=theme)
    panel = find_panel(image)
    assert as_tuple(panel) == (336, 150, 1280, 720)
    assert 0.3 < panel.fill < 1.0


@pytest.mark.parametrize('place', [(336, 150, 1280, 720), (300, 95, 1000, 600),
                                   (700, 400, 640, 400)])
def test_panel_found_wherever_the_window_is(place):
    panel = find_panel(rviz_screenshot(panel=place))
    assert as_tuple(panel) == place
    assert panel.note == ''


def test_marker_across_the_whole_panel_is_reported():
    image = rviz_screenshot(panel=(336, 150, 1280, 720), grid=None, markers=False).copy()
    image[150:870, 1100:1180] = (200, 60, 60)   # a wall from the top to the bottom edge
    panel = find_panel(image)
    assert as_tuple(panel) == (336, 150, 764, 720)
    assert "another background area of the panel's height at x = 1180..1616" in panel.note


def test_hidpi_screenshot_in_device_pixels_and_scaled_to_logical():
    image = rviz_screenshot(screen=(1920, 1080), panel=(336, 151, 1280, 720), scale=2,
                            grid='ortho')
    assert image.shape[:2] == (2160, 3840)
    panel = find_panel(image)
    assert as_tuple(panel) == (672, 302, 2560, 1440)
    assert as_tuple(scaled(panel, 2.0)) == (336, 151, 1280, 720)
    assert as_tuple(scaled(panel, 1.5)) == pytest.approx((448, 201.333333, 1706.666667, 960))


def test_background_colour_other_than_the_default():
    image = rviz_screenshot().copy()
    image[np.all(image == RVIZ_BACKGROUND, axis=2)] = (20, 20, 24)
    with pytest.raises(NoPanelError, match=r'\(48, 48, 48\)'):
        find_panel(image)
    assert as_tuple(find_panel(image, colour=(20, 20, 24))) == (336, 150, 1280, 720)


def test_rgba_screenshot():
    image = rviz_screenshot()
    rgba = np.concatenate([image, np.full(image.shape[:2] + (1,), 255, np.uint8)], axis=2)
    assert as_tuple(find_panel(rgba)) == (336, 150, 1280, 720)


def test_no_rviz_on_the_screen():
    image = rviz_screenshot()
    image = np.where(np.all(image == RVIZ_BACKGROUND, axis=2)[..., None],
                     np.uint8(200), image)
    with pytest.raises(NoPanelError, match='no pixel of the background colour'):
        find_panel(image)


def test_title_bar_of_the_background_colour_alone_is_no_panel():
    image = rviz_screenshot(grid=None, markers=False).copy()
    image[150:870, 336:1616] = (10, 10, 10)   # a minimised panel: only the title bar is grey
    with pytest.raises(NoPanelError, match=r'background colour \(48, 48, 48\)'):
        find_panel(image)


def test_small_patch_and_scattered_pixels_are_no_panel():
    image = np.full((1080, 1920, 3), 200, np.uint8)
    image[500:540, 900:940] = RVIZ_BACKGROUND
    with pytest.raises(NoPanelError):
        find_panel(image)
    noise = np.random.default_rng(1).random((1080, 1920)) < 0.2
    image = np.full((1080, 1920, 3), 200, np.uint8)
    image[noise] = RVIZ_BACKGROUND
    with pytest.raises(NoPanelError, match='background'):
        find_panel(image)


def test_the_larger_of_two_panels_is_taken():
    image = rviz_screenshot(panel=(336, 150, 1280, 720)).copy()
    image[960:1060, 20:260] = RVIZ_BACKGROUND   # another, smaller RViz-coloured area
    assert as_tuple(find_panel(image)) == (336, 150, 1280, 720)


def test_bad_images_are_refused_with_a_reason():
    with pytest.raises(ValueError, match='RGB'):
        find_panel(np.zeros((10, 10)))
    with pytest.raises(ValueError, match='colour'):
        find_panel(np.zeros((10, 10, 3)), colour=(48, 48))


# -- the command line ------------------------------------------------------------------


def save(tmp_path, image, name='screen.png'):
    path = tmp_path / name
    Image.fromarray(image).save(path)
    return str(path)


def test_cli_prints_a_marker_projector_parameter_file(tmp_path, capsys):
    path = save(tmp_path, rviz_screenshot())
    assert cli.main([path]) == 0
    captured = capsys.readouterr()
    assert yaml.safe_load(captured.out) == {'/marker_projector': {'ros__parameters': {
        'screen_offset_x': 336.0, 'screen_offset_y': 150.0,
        'image_width': 1280, 'image_height': 720}}}
    assert 'render panel 1280x720 px at (336, 150)' in captured.err


def test_cli_writes_output_file_with_scale(tmp_path, capsys):
    path = save(tmp_path, rviz_screenshot(panel=(337, 151, 1280, 720), scale=2))
    output = tmp_path / 'panel.yaml'
    assert cli.main([path, '--scale', '2', '--output', str(output)]) == 0
    assert capsys.readouterr().out == ''
    values = yaml.safe_load(output.read_text())['/marker_projector']['ros__parameters']
    assert values == {'screen_offset_x': 337.0, 'screen_offset_y': 151.0,
                      'image_width': 1280, 'image_height': 720}


@pytest.mark.parametrize('make, message', [
    (lambda tmp: save(tmp, np.full((600, 800, 3), 200, np.uint8)), 'no pixel of the background'),
    (lambda tmp: str(tmp / 'missing.png'), 'no such file'),
    (lambda tmp: (tmp / 'notes.png').write_text('not an image') and str(tmp / 'notes.png'),
     'not an image'),
])
def test_cli_errors_are_one_line_and_status_1(tmp_path, capsys, make, message):
    path = make(tmp_path)
    assert cli.main([path]) == 1
    captured = capsys.readouterr()
    assert captured.out == ''
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('find_panel: error:') and message in lines[0]


def test_cli_rejects_a_bad_background_option(tmp_path, capsys):
    path = save(tmp_path, rviz_screenshot())
    with pytest.raises(SystemExit) as exited:
        cli.main([path, '--background', '48,48'])
    assert exited.value.code == 2
    assert 'R,G,B' in capsys.readouterr().err
    assert os.path.exists(path)


def test_cli_warns_when_a_marker_may_split_the_panel(tmp_path, capsys):
    image = rviz_screenshot(grid=None, markers=False).copy()
    image[150:870, 1100:1180] = (200, 60, 60)
    output = tmp_path / 'panel.yaml'
    assert cli.main([save(tmp_path, image), '-o', str(output)]) == 0
    err = capsys.readouterr().err
    assert 'find_panel: warning: another background area' in err
    assert '# warning: another background area' in output.read_text()
