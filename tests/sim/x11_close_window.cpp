// Test helper: waits for a top-level X11 window with the given title and asks it to close, the way a
// window manager does when the user clicks the close button (a WM_DELETE_WINDOW client message).
//   x11_close_window TITLE [TIMEOUT_S]    exit 0: sent; 1: no such window within the timeout
#include <X11/Xlib.h>
#include <X11/Xutil.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

namespace {

Window find_by_title(Display* d, Window w, const std::string& title) {
  char* name = nullptr;
  if (XFetchName(d, w, &name) && name) {
    const bool match = title == name;
    XFree(name);
    if (match) return w;
  }
  Window root = 0, parent = 0, *children = nullptr;
  unsigned n = 0;
  Window found = 0;
  if (XQueryTree(d, w, &root, &parent, &children, &n)) {
    for (unsigned i = 0; i < n && !found; ++i) found = find_by_title(d, children[i], title);
    if (children) XFree(children);
  }
  return found;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: x11_close_window TITLE [TIMEOUT_S]\n");
    return 2;
  }
  const std::string title = argv[1];
  const double timeout_s = argc > 2 ? std::atof(argv[2]) : 20.0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  Display* d = nullptr;
  Window w = 0;
  while (!w && std::chrono::steady_clock::now() < deadline) {
    if (!d) d = XOpenDisplay(nullptr);
    if (d) w = find_by_title(d, DefaultRootWindow(d), title);
    if (!w) usleep(20000);
  }
  if (!w) {
    std::fprintf(stderr, "x11_close_window: no window titled '%s'\n", title.c_str());
    return 1;
  }
  XEvent e;
  std::memset(&e, 0, sizeof e);
  e.xclient.type = ClientMessage;
  e.xclient.window = w;
  e.xclient.message_type = XInternAtom(d, "WM_PROTOCOLS", False);
  e.xclient.format = 32;
  e.xclient.data.l[0] = static_cast<long>(XInternAtom(d, "WM_DELETE_WINDOW", False));
  e.xclient.data.l[1] = CurrentTime;
  XSendEvent(d, w, False, NoEventMask, &e);
  XFlush(d);
  XCloseDisplay(d);
  return 0;
}
