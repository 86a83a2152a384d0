// SPDX-License-Identifier: BSD-3-Clause
#include "io/can/socketcand.hpp"

#include "io/can/candump_log.hpp"
#include "io/number_format.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string_view>
#include <vector>

namespace ehpt::io::can {

namespace {

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

double wall_time_s() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}


// A hexadecimal number of 1..max_digits digits; -1 if it is not one.
// socketcand's rule: an id written with 8 hex digits is a 29-bit one. python-can 4.1 writes ids
// without leading zeros, so an id above 0x7FF is taken as extended whatever its length.
bool is_extended_id_text(std::string_view text, long id) { return text.size() == 8 || id > static_cast<long>(kMaxStandardId); }

long parse_hex(std::string_view s, std::size_t max_digits) {
  if (s.empty() || s.size() > max_digits) return -1;
  long v = 0;
  for (char c : s) {
    const int d = hex_digit_value(c);
    if (d < 0) return -1;
    v = v * 16 + d;
  }
  return v;
}

// The next space-separated token of s (s advances past it).
std::string_view next_token(std::string_view& s) {
  while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
  const std::size_t end = s.find(' ');
  const std::string_view tok = s.substr(0, end);
  s.remove_prefix(end == std::string_view::npos ? s.size() : end);
  return tok;
}

// " < frame 123 1.000000 1122334455667788 >" into buf; returns its length. The leading space
// separates messages: python-can 4.1 drops the character after the last message of each
// read (a frame lost at every read boundary without it), and warns about a trailing one.
// The longest: " < frame 1FFFFFFF " + 20 digits of seconds + ".UUUUUU " + 16 hex digits + " >".
constexpr std::size_t kMaxFrameText = 80;
// A frame's time as "S.UUUUUU", formatted once per microsecond (a sample's frames share it).
struct TimeText {
  std::int64_t us = -1;
  char text[24] = {};
  std::size_t len = 0;
  std::string_view at(double time_s) {
    const auto u = static_cast<std::int64_t>(time_s * 1e6);
    if (u != us) {
      us = u;
      len = static_cast<std::size_t>(io::put_seconds_us(text, u) - text);
    }
    return {text, len};
  }
};
std::size_t format_frame(char (&buf)[kMaxFrameText], const Frame& f, std::string_view time_text) {
  static constexpr std::string_view kHead = " < frame ";
  char* p = std::copy(kHead.begin(), kHead.end(), buf);
  p = f.extended ? io::put_hex(p, f.id & kMaxExtendedId, 8) : io::put_hex(p, f.id & kMaxStandardId, 3);
  *p++ = ' ';
  p = std::copy(time_text.begin(), time_text.end(), p);
  *p++ = ' ';
  for (int i = 0; i < f.len && i < 8; ++i) p = io::put_hex(p, f.data[static_cast<std::size_t>(i)], 2);
  if (f.len > 0) *p++ = ' ';
  *p++ = '>';
  return static_cast<std::size_t>(p - buf);
}

// "< send 123 8 11 22 33 44 55 66 77 88 > "
std::size_t format_send(char (&buf)[kMaxFrameText], const Frame& f) {
  static constexpr std::string_view kHead = "< send ";
  char* p = std::copy(kHead.begin(), kHead.end(), buf);
  p = f.extended ? io::put_hex(p, f.id & kMaxExtendedId, 8) : io::put_hex(p, f.id & kMaxStandardId, 3);
  *p++ = ' ';
  p = io::put_hex(p, f.len, 1);
  for (int i = 0; i < f.len && i < 8; ++i) {
    *p++ = ' ';
    p = io::put_hex(p, f.data[static_cast<std::size_t>(i)], 2);
  }
  static constexpr std::string_view kTail = " > ";
  p = std::copy(kTail.begin(), kTail.end(), p);
  return static_cast<std::size_t>(p - buf);
}

void set_nodelay(int fd) {
  int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
}

// ACK what was just received at once. A stock python-can socketcand client leaves Nagle on, so
// its second frame of a sample waits for the ACK of its first; Linux delays that ACK by up to
// 40 ms unless told otherwise, and TCP_QUICKACK is not sticky (the kernel may leave quick-ACK
// mode again), so it is re-armed after every receive. Measured with tools/pycan_ecu.py on the
// hybrid in lockstep: round trip p50 44 ms without it (22 samples/s).
void set_quickack(int fd) {
  int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_QUICKACK, &one, sizeof one);
}

// One TCP connection with fixed buffers (sized at open: no allocation afterwards).
struct Stream {
  int fd = -1;
  std::vector<char> in, out;
  std::size_t in_len = 0, out_len = 0;
  bool quickack = false;  // ACK every read at once (set_quickack): the peer may have Nagle on

  void reset(int new_fd) {
    fd = new_fd;
    in.assign(16384, '\0');
    out.assign(1 << 18, '\0');
    in_len = out_len = 0;
  }
  void close_fd() {
    if (fd >= 0) ::close(fd);
    fd = -1;
    in_len = out_len = 0;
  }
  // The end of a session, for a peer still there: what is queued goes out, then our FIN.
  // Closing with unread bytes in the kernel's buffer would send a reset instead (python-can
  // clients and loggers then raise ConnectionResetError), so finish_close reads to the
  // peer's end first.
  void begin_close() {
    if (fd < 0) return;
    flush();
    ::shutdown(fd, SHUT_WR);
  }
  // true once the peer has closed its side too (or the connection is gone): then closed
  bool finish_close() {
    if (fd < 0) return true;
    char sink[4096];
    for (int reads = 0;; ++reads) {
      if (reads == 64) return false;  // a peer that keeps sending: the caller's deadline decides
      const ssize_t n = ::recv(fd, sink, sizeof sink, MSG_DONTWAIT);
      if (n > 0) continue;
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return false;
      close_fd();  // 0: the peer's FIN; < 0: the connection failed
      return true;
    }
  }
  // The server's handshake reply, in the run phase too (a client may connect mid-run): queued
  // and sent without waiting. It goes out as its own write, as python-can needs (it compares
  // one whole read with "< ok >"), because a client in its handshake is sent nothing else.
  bool reply(std::string_view s) { return queue(s.data(), s.size()) && flush(); }
  // The client's handshake message, at start-up: its own write, waiting up to 1 s.
  bool write_alone(std::string_view s) const {
    std::size_t done = 0;
    const std::int64_t deadline = now_ns() + 1'000'000'000;
    while (done < s.size()) {
      const ssize_t n = ::send(fd, s.data() + done, s.size() - done, MSG_NOSIGNAL);
      if (n > 0) {
        done += static_cast<std::size_t>(n);
      } else if (n < 0 && (errno == EAGAIN || errno == EINTR) && now_ns() < deadline) {
        pollfd p{fd, POLLOUT, 0};
        ::poll(&p, 1, 10);
      } else {
        return false;
      }
    }
    return true;
  }
  bool queue(const char* s, std::size_t n) {
    if (out_len + n > out.size()) return false;
    std::memcpy(out.data() + out_len, s, n);
    out_len += n;
    return true;
  }
  // Non-blocking; false if the connection is gone.
  bool flush() {
    std::size_t done = 0;
    while (done < out_len) {
      const ssize_t n = ::send(fd, out.data() + done, out_len - done, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        done += static_cast<std::size_t>(n);
      } else if (n < 0 && errno == EINTR) {
        continue;
      } else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        break;
      } else {
        return false;
      }
    }
    std::memmove(out.data(), out.data() + done, out_len - done);
    out_len -= done;
    return true;
  }
  // Reads what is there; false if the peer closed or the connection failed. A read that
  // leaves room in the buffer took all the socket had: no second recv() to hear EAGAIN (what
  // comes after it wakes the next wait()).
  bool read_some() {
    for (;;) {
      if (in_len == in.size()) return true;  // full: the caller takes messages out first
      const std::size_t room = in.size() - in_len;
      const ssize_t n = ::recv(fd, in.data() + in_len, room, MSG_DONTWAIT);
      if (n > 0) {
        in_len += static_cast<std::size_t>(n);
        if (quickack) set_quickack(fd);
        if (static_cast<std::size_t>(n) < room) return true;
        continue;
      }
      if (n == 0) return false;
      if (errno == EINTR) continue;
      return errno == EAGAIN || errno == EWOULDBLOCK;
    }
  }
  // Takes the next complete "< ... >" message out of the input (view valid until the next
  // call that changes `in`); empty if none. Junk before '<' is dropped and counted.
  std::string_view next_message(std::size_t& consumed, std::int64_t& junk) const {
    std::size_t i = consumed;
    bool junk_run = false;  // text between messages counts once per run
    while (i < in_len && in[i] != '<') {
      junk_run = junk_run || (in[i] != ' ' && in[i] != '\n' && in[i] != '\r' && in[i] != '\t');
      ++i;
    }
    junk += junk_run ? 1 : 0;
    consumed = i;
    if (i == in_len) return {};
    const void* end = std::memchr(in.data() + i, '>', in_len - i);
    if (end == nullptr) return {};
    const std::size_t stop = static_cast<std::size_t>(static_cast<const char*>(end) - in.data());
    consumed = stop + 1;
    return {in.data() + i, stop + 1 - i};
  }
  // stalled: parsing stopped for want of room downstream (the buffer is not junk then)
  void drop_consumed(std::size_t consumed, std::int64_t& malformed, bool stalled = false) {
    if (consumed == 0 && in_len == in.size() && !stalled) {  // a full buffer without a message: junk
      ++malformed;
      in_len = 0;
      return;
    }
    std::memmove(in.data(), in.data() + consumed, in_len - consumed);
    in_len -= consumed;
  }
};

// The frames received and not yet taken, in order, each with the client it came from: a
// client may hold at most share() of them (the rest waits in its socket, slowed by TCP's flow
// control), so that one flooding the bus cannot keep the others' frames out.
class FrameRing {
 public:
  static constexpr std::size_t kCapacity = 4096;
  static constexpr std::size_t kSources = 9;  // 8 clients, and "no client" (the ehpt client's own)
  FrameRing() : frames_(kCapacity), from_(kCapacity) {}
  bool full() const { return count_ == frames_.size(); }
  bool full_for(std::size_t source) const { return full() || (source < kSources - 1 && held_[source] >= share()); }
  static constexpr std::size_t share() { return kCapacity / 16; }
  bool push(const Frame& f, std::size_t source = kSources - 1) {
    if (full_for(source)) return false;
    const std::size_t at = (head_ + count_) % frames_.size();
    frames_[at] = f;
    from_[at] = static_cast<std::uint8_t>(source);
    ++held_[source];
    ++count_;
    return true;
  }
  std::size_t pop(std::span<Frame> out) {
    std::size_t n = 0;
    while (n < out.size() && count_ > 0) {
      out[n++] = frames_[head_];
      --held_[from_[head_]];
      head_ = (head_ + 1) % frames_.size();
      --count_;
    }
    return n;
  }

 private:
  std::vector<Frame> frames_;
  std::vector<std::uint8_t> from_;
  std::array<std::size_t, kSources> held_{};
  std::size_t head_ = 0, count_ = 0;
};

// getaddrinfo for a TCP endpoint; the first IPv4/IPv6 address.
bool resolve(const std::string& host, std::uint16_t port, bool passive, sockaddr_storage& addr, socklen_t& len,
             std::string& error) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = passive ? AI_PASSIVE : 0;
  addrinfo* res = nullptr;
  const std::string service = std::to_string(port);
  const int rc = getaddrinfo(host.empty() ? nullptr : host.c_str(), service.c_str(), &hints, &res);
  if (rc != 0 || res == nullptr) {
    error = "cannot resolve host '" + host + "': " + gai_strerror(rc);
    return false;
  }
  std::memcpy(&addr, res->ai_addr, res->ai_addrlen);
  len = res->ai_addrlen;
  freeaddrinfo(res);
  return true;
}

constexpr std::size_t kMaxClients = 8;
// after its last "< ok >", a client gets frames only this much later, so that its read of
// the "< ok >" cannot hold a frame too (python-can compares that read with "< ok >")
constexpr std::int64_t kSettleNs = 50'000'000;
// at the session's end: how long the peers have to close their side (then closed regardless)
constexpr int kCloseWaitMs = 500;

// Closes every stream in order (begin_close, then the peers' ends read, bounded by
// kCloseWaitMs in all); start-up and shutdown only.
template <class Streams>
void close_in_order(Streams& streams) {
  for (Stream* st : streams) st->begin_close();
  const std::int64_t deadline = now_ns() + std::int64_t{kCloseWaitMs} * 1'000'000;
  for (;;) {
    std::vector<pollfd> open;
    for (Stream* st : streams) {
      if (!st->finish_close()) open.push_back({st->fd, POLLIN, 0});
    }
    const std::int64_t left_ms = (deadline - now_ns()) / 1'000'000;
    if (open.empty() || left_ms <= 0) break;
    ::poll(open.data(), open.size(), static_cast<int>(left_ms));
  }
  for (Stream* st : streams) st->close_fd();  // a peer that never closed: closed now
}
// a client that has not reached raw mode this long after connecting loses its slot (the
// handshake takes milliseconds; 8 silent connections must not lock the ECU out)
constexpr std::int64_t kHandshakeNs = 5'000'000'000;
// when every slot is taken, a client in raw mode that has sent nothing this long after its
// handshake (a listener: a logger, or a forgotten client) makes room for a new connection
constexpr std::int64_t kIdleEvictNs = 5'000'000'000;
// the frames one client may hold in the plant's ring (FrameRing::share(), 256): a client
// flooding the bus must not keep the ECU's frames out (200 000 unknown-id frames from one
// client made lockstep waits time out); each pump starts with the next client
// a loop that never calls wait() (the wall clock drains at every step) still takes a new
// connection within this
constexpr std::int64_t kAcceptEveryNs = 10'000'000;

class Server final : public Transport {
 public:
  Server(int listen_fd, std::string name) : listen_fd_(listen_fd), name_(std::move(name)) {
    for (auto& c : clients_) {
      c.stream.reset(-1);
    }
  }
  ~Server() override {
    ::close(listen_fd_);  // no new client while the others are closed
    std::vector<Stream*> open;
    for (auto& c : clients_) {
      if (c.stream.fd >= 0) open.push_back(&c.stream);
    }
    close_in_order(open);
  }

  // Queues the frame for every live client and, unless corked, writes what it can without
  // waiting. It reads nothing and accepts no one: receive() and wait() do that, once per call,
  // not per frame (a sample is four to seven frames).
  bool send(const Frame& f) override {
    char buf[kMaxFrameText];
    const std::size_t n = format_frame(buf, f, time_text_.at(wall_time_s()));
    const std::int64_t now = now_ns();
    bool sent = false;
    for (auto& c : clients_) {
      if (!live(c, now)) continue;
      // corked with a full buffer: what is queued goes out first (a slow client's buffer
      // stays full, and it loses this frame as it would have uncorked)
      if (c.stream.queue(buf, n) || (corked_ && c.stream.flush() && c.stream.queue(buf, n))) {
        sent = true;
      } else {
        ++counters_.slow_drops;  // this client is too slow: its buffer is full (the others got it)
      }
      if (!corked_ && !c.stream.flush()) drop(c);
    }
    if (sent) {
      ++counters_.frames_out;
    } else {
      ++counters_.send_dropped;
    }
    return sent;
  }
  // A sample's frames as one write per client (TCP_NODELAY: one segment, one wake-up of the
  // ECU instead of one per frame).
  void cork() override { corked_ = true; }
  void uncork() override {
    corked_ = false;
    for (auto& c : clients_) {
      if (c.stream.fd >= 0 && c.stream.out_len > 0 && !c.stream.flush()) drop(c);
    }
  }

  std::size_t receive(std::span<Frame> out) override {
    pump();
    return ring_.pop(out);
  }

  bool wait(std::int64_t timeout_ns) override {
    std::array<pollfd, kMaxClients + 1> fds{};
    std::size_t n = 0;
    fds[n++] = {listen_fd_, POLLIN, 0};
    for (auto& c : clients_) {
      if (c.stream.fd < 0) continue;
      fds[n++] = {c.stream.fd, static_cast<short>(POLLIN | (c.stream.out_len > 0 ? POLLOUT : 0)), 0};
    }
    const int ms = timeout_ns <= 0 ? 0 : static_cast<int>(std::min<std::int64_t>((timeout_ns + 999'999) / 1'000'000, 60'000));
    // a client settling: wake when it goes live
    const int rc = ::poll(fds.data(), n, ms);
    if (rc > 0 && (fds[0].revents & POLLIN) != 0) accept_due_ = true;
    return rc > 0;
  }

  bool has_peer() const override {
    const std::int64_t now = now_ns();
    for (const auto& c : clients_) {
      if (live(c, now)) return true;
    }
    return false;
  }
  const TransportCounters& counters() const override { return counters_; }
  std::string describe() const override { return name_; }

 private:
  enum class State { kFree, kHello, kOpen, kRaw };
  struct Client {
    Stream stream;
    State state = State::kFree;
    std::int64_t live_after_ns = 0;
    std::int64_t accepted_ns = 0;  // a client still in its handshake after kHandshakeNs is dropped
    std::int64_t sent_frames = 0;  // since its handshake: a listener that never sends can be evicted
  };

  static bool live(const Client& c, std::int64_t now) { return c.state == State::kRaw && now >= c.live_after_ns; }

  void drop(Client& c) {
    if (c.state == State::kRaw) ++counters_.peers_lost;
    c.stream.close_fd();
    c.state = State::kFree;
  }

  // All non-blocking I/O: new clients, their messages, pending output.
  void pump() {
    const std::int64_t now = now_ns();
    // new connections: when the last wait() saw one, else at most every kAcceptEveryNs (a
    // loop that never waits); not an accept4() per call, which a lockstep period makes a few of
    if (accept_due_ || now >= next_accept_ns_) accept_new();
    // every client in turn, starting one further each pump, each up to its share of the ring
    const std::size_t first = next_first_;
    next_first_ = (next_first_ + 1) % kMaxClients;
    for (std::size_t k = 0; k < kMaxClients; ++k) {
      Client& c = clients_[(first + k) % kMaxClients];
      if (c.state == State::kFree) continue;
      if (c.state != State::kRaw && now - c.accepted_ns > kHandshakeNs) {  // a silent client frees its slot
        ++counters_.error_frames;
        drop(c);
        continue;
      }
      const bool open = c.stream.read_some();
      std::size_t consumed = 0;
      // while the plant has not taken what came in, the rest waits in the socket (TCP's
      // flow control slows the sender), so that no frame is dropped for want of room
      const std::size_t source = static_cast<std::size_t>(&c - clients_.data());
      while (!ring_.full_for(source)) {
        const std::string_view m = c.stream.next_message(consumed, counters_.rx_malformed);
        if (m.empty()) break;
        handle(c, m, now);
        if (c.state == State::kFree) break;
      }
      if (c.state == State::kFree) continue;
      c.stream.drop_consumed(consumed, counters_.rx_malformed, ring_.full_for(source));
      if (!open || (c.stream.out_len > 0 && !c.stream.flush())) drop(c);
    }
  }

  void accept_new() {
    accept_due_ = false;
    next_accept_ns_ = now_ns() + kAcceptEveryNs;
    for (;;) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) break;
      Client* slot = nullptr;
      for (auto& c : clients_) {
        if (c.state == State::kFree) {
          slot = &c;
          break;
        }
      }
      if (slot == nullptr) slot = evict_idle_listener(now_ns());
      if (slot == nullptr) {  // full: refuse politely (a refused connection, not a malformed frame)
        ::close(fd);
        ++counters_.peers_refused;
        continue;
      }
      set_nodelay(fd);
      slot->stream.fd = fd;
      slot->stream.quickack = true;  // its client may have Nagle on (python-can's does)
      slot->stream.in_len = slot->stream.out_len = 0;
      slot->state = State::kHello;
      slot->accepted_ns = now_ns();
      if (!slot->stream.reply("< hi >")) drop(*slot);
    }
  }

  // One message of a client; true if it put a frame into the ring.
  bool handle(Client& c, std::string_view m, std::int64_t now) {
    Frame f;
    switch (parse_socketcand(m, f)) {
      case SocketcandMessage::kOpen:
        if (c.state == State::kHello && c.stream.reply("< ok >")) {
          c.state = State::kOpen;
        } else {
          ++counters_.error_frames;
        }
        return false;
      case SocketcandMessage::kBadChannel:
        // as socketcand: no such bus. Queued, not written at once: no call may block the loop
        ++counters_.error_frames;
        if (!c.stream.queue("< error could not open bus >", 28)) ++counters_.send_dropped;
        return false;
      case SocketcandMessage::kEcho:
        if (!c.stream.queue("< echo >", 8)) ++counters_.send_dropped;
        return false;
      case SocketcandMessage::kRawmode:
        if (c.state == State::kOpen && c.stream.reply("< ok >")) {
          c.state = State::kRaw;
          c.live_after_ns = now + kSettleNs;
          c.sent_frames = 0;
          ++counters_.peers_connected;
        } else {
          ++counters_.error_frames;
        }
        return false;
      case SocketcandMessage::kSend:
        if (c.state != State::kRaw) {
          ++counters_.error_frames;
          return false;
        }
        ++c.sent_frames;
        forward(c, f, now);
        if (ring_.push(f, static_cast<std::size_t>(&c - clients_.data()))) {
          ++counters_.frames_in;
          return true;
        }
        ++counters_.send_dropped;  // the plant did not keep up: the frame is lost
        return false;
      case SocketcandMessage::kMalformed:
        ++counters_.rx_malformed;
        return false;
      default:
        ++counters_.error_frames;  // a command we do not serve (bcmode, echo, ...)
        return false;
    }
  }

  // Every slot taken and a new connection waiting: the raw-mode client that has sent nothing
  // for the longest (at least kIdleEvictNs since its handshake) gives up its slot; nullptr if none.
  Client* evict_idle_listener(std::int64_t now) {
    Client* oldest = nullptr;
    for (auto& c : clients_) {
      if (c.state != State::kRaw || c.sent_frames != 0 || now - c.live_after_ns < kIdleEvictNs) continue;
      if (oldest == nullptr || c.live_after_ns < oldest->live_after_ns) oldest = &c;
    }
    if (oldest == nullptr) return nullptr;
    ++counters_.peers_evicted;
    drop(*oldest);
    return oldest;
  }

  // a bus: the other clients hear what one sends
  void forward(const Client& from, const Frame& f, std::int64_t now) {
    char buf[kMaxFrameText];
    const std::size_t n = format_frame(buf, f, time_text_.at(wall_time_s()));
    for (auto& c : clients_) {
      if (&c == &from || !live(c, now)) continue;
      if (!c.stream.queue(buf, n)) ++counters_.slow_drops;
    }
  }

  int listen_fd_;
  std::string name_;
  std::array<Client, kMaxClients> clients_;
  std::size_t next_first_ = 0;  // the client pump() reads first (round robin)
  bool corked_ = false;          // send() queues only; uncork() writes
  TimeText time_text_;
  bool accept_due_ = true;       // the listening socket was readable at the last wait()
  std::int64_t next_accept_ns_ = 0;
  FrameRing ring_;
  TransportCounters counters_;
};

class Client final : public Transport {
 public:
  Client(int fd, std::string name) : name_(std::move(name)) {
    stream_.reset(fd);
    stream_.quickack = true;  // a socketcand daemon, or any server, may have Nagle on too
  }
  ~Client() override {
    std::vector<Stream*> one{&stream_};
    close_in_order(one);
  }

  // start-up: the handshake, within the deadline; refused() after a failed one: the server
  // closed before its greeting (every slot taken), worth trying again
  bool handshake(const std::string& channel, std::int64_t deadline_ns, std::string& error) {
    const std::string open = "< open " + channel + " >";
    const char* expect[] = {"hi", "ok", "ok"};
    for (int step = 0; step < 3; ++step) {
      std::string_view m;
      std::size_t consumed = 0;
      std::int64_t junk = 0;
      while ((m = stream_.next_message(consumed, junk)).empty()) {
        if (now_ns() > deadline_ns) {
          error = "no socketcand handshake (waited for '< " + std::string(expect[step]) + " >')";
          return false;
        }
        pollfd p{stream_.fd, POLLIN, 0};
        ::poll(&p, 1, 50);
        if (!stream_.read_some()) {
          refused_ = step == 0;  // closed before its "< hi >": a server with every slot taken
          error = refused_ ? "the server refused the connection (every one of its client slots is taken)"
                           : "the server closed the connection during the handshake";
          return false;
        }
        consumed = 0;
      }
      Frame f;
      const SocketcandMessage kind = parse_socketcand(m, f);
      const std::string text(m);
      stream_.drop_consumed(consumed, junk);
      if (kind != (step == 0 ? SocketcandMessage::kHi : SocketcandMessage::kOk)) {
        error = "unexpected socketcand reply '" + text + "' (wanted '< " + expect[step] + " >')";
        return false;
      }
      if (step < 2 && !stream_.write_alone(step == 0 ? std::string_view(open) : std::string_view("< rawmode >"))) {
        error = "cannot write to the server";
        return false;
      }
    }
    connected_ = true;
    return true;
  }
  bool refused() const { return refused_; }

  bool send(const Frame& f) override {
    if (!connected_) {
      ++counters_.send_dropped;
      return false;
    }
    char buf[kMaxFrameText];
    const std::size_t n = format_send(buf, f);
    if (!stream_.queue(buf, n) && !(corked_ && stream_.flush() && stream_.queue(buf, n))) {
      ++counters_.send_dropped;
      return false;
    }
    if (!corked_ && !stream_.flush()) lose();
    ++counters_.frames_out;
    return true;
  }
  // A command's frames as one write (one segment: the plant wakes once for them).
  void cork() override { corked_ = true; }
  void uncork() override {
    corked_ = false;
    if (connected_ && stream_.out_len > 0 && !stream_.flush()) lose();
  }

  std::size_t receive(std::span<Frame> out) override {
    if (connected_) {
      const bool open = stream_.read_some();
      std::size_t consumed = 0;
      while (!ring_.full()) {  // the rest waits in the socket until the ECU has taken these
        const std::string_view m = stream_.next_message(consumed, counters_.rx_malformed);
        if (m.empty()) break;
        Frame f;
        switch (parse_socketcand(m, f)) {
          case SocketcandMessage::kFrame:
            if (ring_.push(f)) {
              ++counters_.frames_in;
            } else {
              ++counters_.send_dropped;
            }
            break;
          case SocketcandMessage::kMalformed: ++counters_.rx_malformed; break;
          default: ++counters_.error_frames; break;
        }
      }
      stream_.drop_consumed(consumed, counters_.rx_malformed, ring_.full());
      if (!open || (stream_.out_len > 0 && !stream_.flush())) lose();
    }
    return ring_.pop(out);
  }

  bool wait(std::int64_t timeout_ns) override {
    if (!connected_) return false;
    pollfd p{stream_.fd, static_cast<short>(POLLIN | (stream_.out_len > 0 ? POLLOUT : 0)), 0};
    const int ms = timeout_ns <= 0 ? 0 : static_cast<int>(std::min<std::int64_t>((timeout_ns + 999'999) / 1'000'000, 60'000));
    return ::poll(&p, 1, ms) > 0;
  }
  bool has_peer() const override { return connected_; }
  const TransportCounters& counters() const override { return counters_; }
  std::string describe() const override { return name_; }

 private:
  void lose() {
    if (connected_) ++counters_.peers_lost;
    connected_ = false;
  }
  Stream stream_;
  bool connected_ = false;
  bool corked_ = false;   // send() queues only; uncork() writes
  bool refused_ = false;  // the handshake ended before "< hi >"
  std::string name_;
  FrameRing ring_;
  TransportCounters counters_;
};

}  // namespace

SocketcandMessage parse_socketcand(std::string_view m, Frame& frame) {
  if (m.size() < 3 || m.front() != '<' || m.back() != '>') return SocketcandMessage::kMalformed;
  std::string_view body = m.substr(1, m.size() - 2);
  const std::string_view word = next_token(body);
  if (word == "hi") return SocketcandMessage::kHi;
  if (word == "ok") return SocketcandMessage::kOk;
  if (word == "rawmode") return SocketcandMessage::kRawmode;
  if (word == "echo") return next_token(body).empty() ? SocketcandMessage::kEcho : SocketcandMessage::kMalformed;
  if (word == "open") {
    const std::string_view channel = next_token(body);
    if (channel.empty() || !next_token(body).empty()) return SocketcandMessage::kMalformed;
    const bool name_ok = channel.size() <= 15 && std::all_of(channel.begin(), channel.end(), [](char c) {
      return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' || c == '.';
    });
    return name_ok ? SocketcandMessage::kOpen : SocketcandMessage::kBadChannel;
  }
  if (word == "error") return SocketcandMessage::kError;
  Frame f;
  if (word == "send") {  // < send ID LEN B0 B1 ... >
    const std::string_view id_text = next_token(body);
    const long id = parse_hex(id_text, 8);
    const long len = parse_hex(next_token(body), 1);
    if (id < 0 || id > static_cast<long>(kMaxExtendedId) || len < 0 || len > 8) return SocketcandMessage::kMalformed;
    f.id = static_cast<std::uint32_t>(id);
    f.extended = is_extended_id_text(id_text, id);
    f.len = static_cast<std::uint8_t>(len);
    for (long i = 0; i < len; ++i) {
      const long b = parse_hex(next_token(body), 2);
      if (b < 0) return SocketcandMessage::kMalformed;
      f.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(b);
    }
    if (!next_token(body).empty()) return SocketcandMessage::kMalformed;
    frame = f;
    return SocketcandMessage::kSend;
  }
  if (word == "frame") {  // < frame ID SECS.USECS DATA >
    const std::string_view id_text = next_token(body);
    const long id = parse_hex(id_text, 8);
    const std::string_view time = next_token(body);
    const std::string_view data = next_token(body);
    if (id < 0 || id > static_cast<long>(kMaxExtendedId) || time.empty() || data.size() % 2 != 0 || data.size() > 16 ||
        !next_token(body).empty()) {
      return SocketcandMessage::kMalformed;
    }
    f.id = static_cast<std::uint32_t>(id);
    f.extended = is_extended_id_text(id_text, id);
    f.len = static_cast<std::uint8_t>(data.size() / 2);
    for (std::size_t i = 0; i < f.len; ++i) {
      const long b = parse_hex(data.substr(2 * i, 2), 2);
      if (b < 0) return SocketcandMessage::kMalformed;
      f.data[i] = static_cast<std::uint8_t>(b);
    }
    frame = f;
    return SocketcandMessage::kFrame;
  }
  return SocketcandMessage::kOther;
}

std::unique_ptr<Transport> open_socketcand_server(const std::string& host, std::uint16_t port, std::string& error) {
  const std::string name = "socketcand:" + host + ":" + std::to_string(port);
  sockaddr_storage addr{};
  socklen_t len = 0;
  if (!resolve(host, port, true, addr, len, error)) {
    error = name + ": " + error;
    return nullptr;
  }
  const int fd = ::socket(addr.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    error = name + ": cannot create a socket: " + std::strerror(errno);
    return nullptr;
  }
  int one = 1;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);  // a restart binds over TIME_WAIT
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), len) != 0 || ::listen(fd, 8) != 0) {
    const int e = errno;
    ::close(fd);
    error = name + ": cannot listen: " + (e == EADDRINUSE ? std::string("port in use") : std::string(std::strerror(e)));
    return nullptr;
  }
  return std::make_unique<Server>(fd, name);
}

namespace {
std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", s);
  return buf;
}
}  // namespace

// Connects to addr, trying a refused connection again every 20 ms until the deadline; the
// socket, or -1 with error set.
static int connect_until(const sockaddr_storage& addr, socklen_t len, std::int64_t deadline, const std::string& name,
                         double timeout_s, std::string& error) {
  for (;;) {
    const int fd = ::socket(addr.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) {
      error = name + ": cannot create a socket: " + std::strerror(errno);
      return -1;
    }
    int e = 0;
    if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), len) != 0 && errno != EINPROGRESS) {
      e = errno;
    } else {
      pollfd p{fd, POLLOUT, 0};
      const int ms = static_cast<int>(std::max<std::int64_t>(0, (deadline - now_ns()) / 1'000'000));
      socklen_t so_len = sizeof e;
      if (::poll(&p, 1, ms) != 1) {
        e = ETIMEDOUT;
      } else if (getsockopt(fd, SOL_SOCKET, SO_ERROR, &e, &so_len) != 0) {
        e = errno;
      }
    }
    if (e == 0) return fd;
    ::close(fd);
    if (e == ECONNREFUSED && now_ns() + 20'000'000 < deadline) {
      ::usleep(20'000);
      continue;
    }
    error = name + ": cannot connect: " + (e == ETIMEDOUT ? std::string("timed out") : std::string(std::strerror(e))) +
            (e == ECONNREFUSED ? " (nothing listened there within the " + seconds_text(timeout_s) + " s it waits)" : "");
    return -1;
  }
}

std::unique_ptr<Transport> open_socketcand_client(const std::string& host, std::uint16_t port,
                                                  const std::string& channel, double timeout_s, std::string& error) {
  const std::string name = "socketcand:" + host + ":" + std::to_string(port);
  sockaddr_storage addr{};
  socklen_t len = 0;
  if (!resolve(host, port, false, addr, len, error)) {
    error = name + ": " + error;
    return nullptr;
  }
  const std::int64_t deadline = now_ns() + static_cast<std::int64_t>(timeout_s * 1e9);
  for (;;) {
    // A plant that is still loading its scenario does not listen yet: a refused connection is
    // tried again every 20 ms until the deadline (an ECU started next to its plant needs no sleep).
    const int fd = connect_until(addr, len, deadline, name, timeout_s, error);
    if (fd < 0) return nullptr;
    set_nodelay(fd);
    auto client = std::make_unique<Client>(fd, name);
    if (client->handshake(channel, deadline, error)) return client;
    // a plant whose client slots are all taken closes at once: tried again every 200 ms
    const bool refused = client->refused();
    client.reset();
    if (refused && now_ns() + 200'000'000 < deadline) {
      ::usleep(200'000);
      continue;
    }
    error = name + ": " + error + (refused ? " (tried again for the " + seconds_text(timeout_s) + " s it waits)" : "");
    return nullptr;
  }
}

}  // namespace ehpt::io::can
