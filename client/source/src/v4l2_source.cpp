// V4l2Source: a webcam through libv4l2 (v4l2_open / v4l2_ioctl / v4l2_mmap), memory-mapped
// streaming I/O. Format preference: MJPEG (the JPEG is forwarded to the server as is), then
// YUYV, then BGR24 as libv4l2 converts it from whatever the device has.
#include <fcntl.h>
#include <libv4l2.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/mman.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arlight/common/error.hpp"
#include "arlight/source/source.hpp"

namespace arlight::source {

namespace {

std::string fourcc_name(std::uint32_t f) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = char((f >> (8 * i)) & 0xff);
    s += (c >= 32 && c < 127) ? c : '?';
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// v4l2_ioctl, retried when a signal interrupts it.
int xioctl(int fd, unsigned long request, void* arg) {
  int r;
  do r = v4l2_ioctl(fd, request, arg);
  while (r == -1 && errno == EINTR);
  return r;
}

std::string errno_text(int e) { return std::strerror(e); }

struct Buffer {
  void* start = MAP_FAILED;
  std::size_t length = 0;
};

// A control's current value, if the device has the control and it is readable.
std::optional<v4l2_queryctrl> query_control(int fd, std::uint32_t id) {
  v4l2_queryctrl q{};
  q.id = id;
  if (xioctl(fd, VIDIOC_QUERYCTRL, &q) == -1) return std::nullopt;
  if (q.flags & (V4L2_CTRL_FLAG_DISABLED | V4L2_CTRL_FLAG_WRITE_ONLY)) return std::nullopt;
  return q;
}

std::optional<std::int32_t> get_control(int fd, std::uint32_t id) {
  v4l2_control c{};
  c.id = id;
  if (xioctl(fd, VIDIOC_G_CTRL, &c) == -1) return std::nullopt;
  return c.value;
}

bool set_control(int fd, std::uint32_t id, std::int32_t value) {
  v4l2_control c{};
  c.id = id;
  c.value = value;
  return xioctl(fd, VIDIOC_S_CTRL, &c) != -1;
}

}  // namespace

struct V4l2Source::Impl {
  std::string device;
  SourceOptions options;
  int fd = -1;
  std::vector<Buffer> buffers;
  bool streaming = false;
  std::uint32_t pixelformat = 0;
  int width = 0, height = 0;
  std::uint32_t bytesperline = 0;
  std::string card, driver, bus;
  std::vector<std::string> offered;  // what VIDIOC_ENUM_FMT listed
  CameraIntrinsics camera;
  bool calibrated = false;
  std::optional<v4l2_queryctrl> exposure_ctrl, gain_ctrl;
  std::optional<std::int32_t> auto_mode;  // V4L2_CID_EXPOSURE_AUTO as the device started
  int manual_frames = 0;                  // frames left at a requested exposure
  double fps = 0;
  std::size_t count = 0;
  std::optional<double> first_timestamp;

  std::string fail(const std::string& what) const { return "v4l2 device '" + device + "': " + what; }

  void open_device();
  void check_capabilities();
  void negotiate_format();
  void set_rate();
  void setup_controls();
  void start_streaming();
  void close_device();
};

void V4l2Source::Impl::open_device() {
  struct stat st {};
  if (::stat(device.c_str(), &st) == -1)
    throw InputError(fail(errno == ENOENT ? "no such device (is the webcam plugged in?)"
                                          : "cannot stat: " + errno_text(errno)));
  if (!S_ISCHR(st.st_mode))
    throw InputError(fail("not a V4L2 capture device (not a character device)"));
  const int raw = ::open(device.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (raw == -1) {
    const int e = errno;
    if (e == EBUSY) throw InputError(fail("busy: another program is using it"));
    if (e == EACCES)
      throw InputError(fail("permission denied (is the user in the 'video' group?)"));
    throw InputError(fail("cannot open: " + errno_text(e)));
  }
  // Ask the kernel first, so a character device that is no V4L2 device (/dev/null, a serial
  // port) gets a clear error instead of libv4l2's complaints on stderr.
  v4l2_capability cap{};
  if (::ioctl(raw, VIDIOC_QUERYCAP, &cap) == -1) {
    const int e = errno;
    ::close(raw);
    throw InputError(fail("not a V4L2 capture device (VIDIOC_QUERYCAP: " + errno_text(e) + ")"));
  }
  fd = v4l2_fd_open(raw, 0);
  if (fd == -1) {
    const int e = errno;
    ::close(raw);
    throw InputError(fail("libv4l2 cannot use it: " + errno_text(e)));
  }
}

void V4l2Source::Impl::check_capabilities() {
  v4l2_capability cap{};
  if (xioctl(fd, VIDIOC_QUERYCAP, &cap) == -1)
    throw InputError(fail("not a V4L2 capture device (VIDIOC_QUERYCAP: " + errno_text(errno) +
                          ")"));
  card = reinterpret_cast<const char*>(cap.card);
  driver = reinterpret_cast<const char*>(cap.driver);
  bus = reinterpret_cast<const char*>(cap.bus_info);
  const std::uint32_t caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE))
    throw InputError(fail("'" + card + "' (" + driver +
                          ") is not a V4L2 capture device (no video capture capability; "
                          "a webcam often has a second /dev/video node for metadata)"));
  if (!(caps & V4L2_CAP_STREAMING))
    throw InputError(fail("'" + card + "' does not support streaming I/O"));
}

void V4l2Source::Impl::negotiate_format() {
  for (std::uint32_t i = 0;; ++i) {
    v4l2_fmtdesc d{};
    d.index = i;
    d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(fd, VIDIOC_ENUM_FMT, &d) == -1) break;
    offered.push_back(fourcc_name(d.pixelformat) +
                      ((d.flags & V4L2_FMT_FLAG_EMULATED) ? " (libv4l2 conversion)" : ""));
  }
  std::string tried;
  for (const std::uint32_t want : {V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_BGR24}) {
    v4l2_format f{};
    f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    f.fmt.pix.width = std::uint32_t(options.width);
    f.fmt.pix.height = std::uint32_t(options.height);
    f.fmt.pix.pixelformat = want;
    f.fmt.pix.field = V4L2_FIELD_NONE;
    tried += (tried.empty() ? "" : ", ") + fourcc_name(want);
    if (xioctl(fd, VIDIOC_S_FMT, &f) == -1) {
      if (errno == EBUSY) throw InputError(fail("busy: another program is streaming from it"));
      continue;
    }
    if (f.fmt.pix.pixelformat != want) continue;  // the driver substituted another format
    pixelformat = want;
    width = int(f.fmt.pix.width);
    height = int(f.fmt.pix.height);
    bytesperline = f.fmt.pix.bytesperline;
    if (width != options.width || height != options.height)
      spdlog::warn("{}", fail("asked for " + std::to_string(options.width) + "x" +
                              std::to_string(options.height) + ", the device gives " +
                              std::to_string(width) + "x" + std::to_string(height)));
    return;
  }
  std::string list;
  for (const std::string& s : offered) list += (list.empty() ? "" : ", ") + s;
  throw InputError(fail("no supported format: tried " + tried + "; the device offers " +
                        (list.empty() ? std::string("nothing") : list)));
}

void V4l2Source::Impl::set_rate() {
  if (!(options.fps > 0)) return;
  v4l2_streamparm p{};
  p.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd, VIDIOC_G_PARM, &p) == -1 || !(p.parm.capture.capability & V4L2_CAP_TIMEPERFRAME))
    return;
  p.parm.capture.timeperframe.numerator = 1000;
  p.parm.capture.timeperframe.denominator = std::uint32_t(std::lround(options.fps * 1000));
  if (xioctl(fd, VIDIOC_S_PARM, &p) != -1 && p.parm.capture.timeperframe.numerator > 0)
    fps = double(p.parm.capture.timeperframe.denominator) / p.parm.capture.timeperframe.numerator;
}

void V4l2Source::Impl::setup_controls() {
  exposure_ctrl = query_control(fd, V4L2_CID_EXPOSURE_ABSOLUTE);
  gain_ctrl = query_control(fd, V4L2_CID_GAIN);
  auto_mode = get_control(fd, V4L2_CID_EXPOSURE_AUTO);
  if (!options.exposure) return;
  const double s = *options.exposure;
  if (!(s > 0)) throw InputError(fail("manual exposure must be > 0 seconds"));
  if (!exposure_ctrl) {
    spdlog::warn("{}", fail("no exposure_time_absolute control; manual exposure not set"));
    return;
  }
  if (!set_control(fd, V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL))
    spdlog::warn("{}", fail("cannot switch auto exposure off: " + errno_text(errno)));
  // V4L2_CID_EXPOSURE_ABSOLUTE counts 100 microseconds.
  const auto units = std::int32_t(std::clamp<long>(std::lround(s / 100e-6),
                                                    exposure_ctrl->minimum, exposure_ctrl->maximum));
  if (!set_control(fd, V4L2_CID_EXPOSURE_ABSOLUTE, units))
    spdlog::warn("{}", fail("cannot set the exposure: " + errno_text(errno)));
}

void V4l2Source::Impl::start_streaming() {
  v4l2_requestbuffers req{};
  req.count = 4;
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd, VIDIOC_REQBUFS, &req) == -1)
    throw InputError(fail(errno == EBUSY ? "busy: another program is streaming from it"
                                         : "VIDIOC_REQBUFS (mmap): " + errno_text(errno)));
  if (req.count < 2) throw InputError(fail("too few capture buffers"));
  for (std::uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = i;
    if (xioctl(fd, VIDIOC_QUERYBUF, &b) == -1)
      throw InputError(fail("VIDIOC_QUERYBUF: " + errno_text(errno)));
    Buffer buf;
    buf.length = b.length;
    buf.start = v4l2_mmap(nullptr, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, b.m.offset);
    if (buf.start == MAP_FAILED) throw InputError(fail("mmap: " + errno_text(errno)));
    buffers.push_back(buf);
    if (xioctl(fd, VIDIOC_QBUF, &b) == -1)
      throw InputError(fail("VIDIOC_QBUF: " + errno_text(errno)));
  }
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd, VIDIOC_STREAMON, &type) == -1)
    throw InputError(fail(errno == EBUSY ? "busy: another program is streaming from it"
                                         : "VIDIOC_STREAMON: " + errno_text(errno)));
  streaming = true;
}

void V4l2Source::Impl::close_device() {
  if (fd == -1) return;
  // UVC cameras keep their controls after close: never leave one in a requested exposure.
  if (manual_frames > 0 && auto_mode) set_control(fd, V4L2_CID_EXPOSURE_AUTO, *auto_mode);
  if (streaming) {
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    xioctl(fd, VIDIOC_STREAMOFF, &type);
  }
  for (const Buffer& b : buffers)
    if (b.start != MAP_FAILED) v4l2_munmap(b.start, b.length);
  buffers.clear();
  v4l2_close(fd);
  fd = -1;
}

V4l2Source::V4l2Source(const std::string& device, const SourceOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.device = device;
  m.options = options;
  if (options.width < 1 || options.height < 1 || options.width > 16384 || options.height > 16384)
    throw InputError(m.fail("requested size must be 1..16384 pixels a side"));
  try {
    m.open_device();
    m.check_capabilities();
    m.negotiate_format();
    m.set_rate();
    m.setup_controls();
    if (!options.intrinsics_file.empty()) {
      m.camera = load_intrinsics(options.intrinsics_file, m.width, m.height);
      m.calibrated = true;
    } else {
      m.camera = CameraIntrinsics::from_fov(m.width, m.height, 60.0);
      spdlog::warn("{}", m.fail("no intrinsics file: assuming a 60 degree horizontal field of "
                                "view without distortion (tracking will be approximate)"));
    }
    m.start_streaming();
  } catch (...) {
    m.close_device();
    throw;
  }
  spdlog::info("{}", describe());
}

V4l2Source::~V4l2Source() { impl_->close_device(); }

std::optional<SourceFrame> V4l2Source::next() {
  Impl& m = *impl_;
  for (;;) {
    pollfd p{m.fd, POLLIN, 0};
    const int r = ::poll(&p, 1, int(std::lround(m.options.timeout_s * 1000)));
    if (r == -1 && errno == EINTR) continue;
    if (r == -1) throw InputError(m.fail("poll: " + errno_text(errno)));
    if (r == 0)
      throw InputError(m.fail("no frame within " + std::to_string(m.options.timeout_s) + " s"));
    if (p.revents & (POLLERR | POLLHUP | POLLNVAL))
      throw InputError(m.fail("the device stopped delivering frames (unplugged?)"));
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    if (xioctl(m.fd, VIDIOC_DQBUF, &b) == -1) {
      if (errno == EAGAIN) continue;
      throw InputError(m.fail(errno == ENODEV ? "the device is gone (unplugged?)"
                                              : "VIDIOC_DQBUF: " + errno_text(errno)));
    }
    SourceFrame out;
    const auto* data = static_cast<const std::uint8_t*>(m.buffers.at(b.index).start);
    const std::size_t used = std::min<std::size_t>(b.bytesused, m.buffers[b.index].length);
    const bool corrupt = (b.flags & V4L2_BUF_FLAG_ERROR) != 0;
    if (!corrupt) {
      if (m.pixelformat == V4L2_PIX_FMT_MJPEG) {
        out.jpeg.assign(data, data + used);
        out.bgr = cv::imdecode(out.jpeg, cv::IMREAD_COLOR);
      } else if (m.pixelformat == V4L2_PIX_FMT_YUYV) {
        const cv::Mat yuyv(m.height, m.width, CV_8UC2, const_cast<std::uint8_t*>(data),
                           m.bytesperline ? m.bytesperline : std::size_t(m.width) * 2);
        cv::cvtColor(yuyv, out.bgr, cv::COLOR_YUV2BGR_YUYV);
      } else {
        const cv::Mat bgr(m.height, m.width, CV_8UC3, const_cast<std::uint8_t*>(data),
                          m.bytesperline ? m.bytesperline : std::size_t(m.width) * 3);
        out.bgr = bgr.clone();
      }
    }
    const double ts = double(b.timestamp.tv_sec) + 1e-6 * double(b.timestamp.tv_usec);
    if (xioctl(m.fd, VIDIOC_QBUF, &b) == -1)
      throw InputError(m.fail("VIDIOC_QBUF: " + errno_text(errno)));
    if (out.bgr.empty() || out.bgr.cols != m.width || out.bgr.rows != m.height) {
      spdlog::warn("{}", m.fail("dropping a corrupt frame"));
      continue;
    }
    if (!m.first_timestamp) m.first_timestamp = ts;
    out.timestamp = ts - *m.first_timestamp;
    if (m.exposure_ctrl)
      if (const auto v = get_control(m.fd, V4L2_CID_EXPOSURE_ABSOLUTE)) out.exposure = *v * 100e-6;
    // V4L2 gains are in device units: report them relative to the device's default gain.
    if (m.gain_ctrl && m.gain_ctrl->default_value > 0)
      if (const auto v = get_control(m.fd, V4L2_CID_GAIN); v && *v > 0)
        out.gain = double(*v) / m.gain_ctrl->default_value;
    out.index = m.count++;
    if (m.manual_frames > 0) {
      out.exposure_requested = true;
      if (--m.manual_frames == 0 && m.auto_mode &&
          !set_control(m.fd, V4L2_CID_EXPOSURE_AUTO, *m.auto_mode))
        spdlog::warn("{}", m.fail("cannot return to auto exposure: " + errno_text(errno)));
    }
    return out;
  }
}

bool V4l2Source::request_exposure(double exposure_gain) {
  Impl& m = *impl_;
  // A fixed --exposure is the user's; a device without the controls cannot.
  if (m.options.exposure || !m.exposure_ctrl || !m.auto_mode) return false;
  if (!(exposure_gain > 0.0)) {
    if (m.manual_frames > 0) set_control(m.fd, V4L2_CID_EXPOSURE_AUTO, *m.auto_mode);
    m.manual_frames = 0;
    return true;
  }
  // V4L2_CID_EXPOSURE_ABSOLUTE counts 100 microseconds; the gain stays where it is.
  const auto units = std::int32_t(std::clamp<long>(std::lround(exposure_gain / 100e-6),
                                                    m.exposure_ctrl->minimum,
                                                    m.exposure_ctrl->maximum));
  if (!set_control(m.fd, V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL) ||
      !set_control(m.fd, V4L2_CID_EXPOSURE_ABSOLUTE, units)) {
    spdlog::warn("{}", m.fail("cannot set a requested exposure: " + errno_text(errno)));
    return false;
  }
  m.manual_frames = 1;
  return true;
}

CameraIntrinsics V4l2Source::intrinsics() const { return impl_->camera; }

std::string V4l2Source::device_id() const {
  // The card name keys the response curve: the same webcam model shares one.
  return "v4l2:" + impl_->card;
}

std::string V4l2Source::describe() const {
  const Impl& m = *impl_;
  std::string s = "v4l2:" + m.device + " '" + m.card + "' (" + m.driver + ", " + m.bus + "): " +
                  fourcc_name(m.pixelformat) + " " + std::to_string(m.width) + "x" +
                  std::to_string(m.height);
  if (m.fps > 0) s += " at " + std::to_string(int(std::lround(m.fps))) + " fps";
  s += m.calibrated ? ", calibrated" : ", uncalibrated (60 deg fov)";
  s += m.exposure_ctrl ? ", exposure readable" : ", no exposure control";
  return s;
}

}  // namespace arlight::source
