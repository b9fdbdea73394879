// The viewer's single page (view/page.html, compiled in): sliders and a gesture picker, the held-out
// poses to step through, an orbit camera dragged with the mouse, the Gaussian count and frame
// times on screen, and a button that saves the pose. It keeps at most one render request in flight
// and sends only the latest state when it returns, so no stale frames queue up.
#pragma once

namespace handscs {

const char* view_page_html();

}  // namespace handscs
