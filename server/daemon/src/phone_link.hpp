// What a user needs to connect a phone to arlightd's web port: a certificate the page is served
// with (self-signed in the data folder when none is given), the page's URL with the device id and
// token in its fragment (never sent in an HTTP request), and that URL as a QR code for the
// terminal.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace arlight::daemon {

struct CertificateFiles {
  std::filesystem::path cert, key;  // PEM
  bool created = false;             // made now (a phone must accept it once more)
};

// DIR/self-signed-cert.pem and its key (mode 0600), for `names` (DNS names and IP addresses, all
// in the subjectAltName; the first is the subject's CN). Kept across restarts, so a phone accepts
// it once; made anew when missing, unreadable, within 30 days of expiry, or made for other names.
CertificateFiles ensure_self_signed_certificate(const std::filesystem::path& dir,
                                                const std::vector<std::string>& names);

// The names a phone on the local network may reach this machine by: localhost, 127.0.0.1, the
// host name and every non-loopback IPv4 address of an interface that is up.
std::vector<std::string> local_names();

// The host to put in the phone's URL for a listener bound to `bind_host`: the address itself,
// or for a wildcard (0.0.0.0, ::) the first non-loopback IPv4 address, else the host name.
std::string reachable_host(const std::string& bind_host);

// https://HOST:PORT/#device=D&token=T (values percent-encoded; IPv6 hosts bracketed).
std::string phone_url(const std::string& host, unsigned port, const std::string& device_id,
                      const std::string& token);

// The QR code of `text` (libqrencode, error correction level M): modules[y][x], true = dark,
// without the quiet zone. InputError when the text does not fit a QR code.
std::vector<std::vector<bool>> qr_modules(const std::string& text);

// The modules for a terminal: two module rows per text line with half blocks, a 2-module light
// quiet zone; light modules are drawn (the block characters), dark ones are spaces. With
// `colour`, ANSI colours force black on white so the code reads the same on any terminal theme.
std::string qr_terminal(const std::vector<std::vector<bool>>& modules, bool colour);

// The modules as an SVG image (one unit a module, a 4-module light quiet zone, one path of the
// dark modules), for a page to show.
std::string qr_svg(const std::vector<std::vector<bool>>& modules);

// The links a phone page shows as QR codes: its watch link (issue 35), https://HOST/three.html#F
// for /qr.svg?three=F, and its join link (issue 49: another phone capturing into the session),
// https://HOST/#F for /qr.svg?join=F, reaching `host` (the request's Host header); "" when
// either is not what such a link holds (a host of letters, digits, '.', '-', ':' and brackets;
// a fragment of at most 512 URL-safe characters).
std::string watch_link(std::string_view host, std::string_view query);

}  // namespace arlight::daemon
