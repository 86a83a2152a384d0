// SPDX-License-Identifier: BSD-3-Clause
// The socketcand server (io/can/socketcand.hpp) on 127.0.0.1: eight clients that connect and
// never finish their handshake cannot lock an ECU out; their slots are freed after 5 s; the
// session ends with an orderly close.
#include <arpa/inet.h>
#include <linux/tcp.h>  // struct tcp_info with tcpi_data_segs_in (netinet/tcp.h's lacks it)
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "io/can/socketcand.hpp"

namespace ehpt::io::can {
namespace {

int connect_to(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  return fd;
}

// a free port: bound to 0 by the kernel, then released
std::uint16_t free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return ntohs(a.sin_port);
}

TEST(SocketcandServer, SilentClientsLoseTheirSlotsAndAnEcuGetsIn) {
  const std::uint16_t port = free_port();
  std::string error;
  auto server = open_socketcand_server("127.0.0.1", port, error);
  ASSERT_TRUE(server) << error;
  std::vector<int> silent;
  for (int i = 0; i < 8; ++i) silent.push_back(connect_to(port));
  Frame none[4];
  server->receive(none);  // accepts them: every slot taken
  // an ECU now: refused (closed at once) while every slot is taken; it tries again
  std::unique_ptr<Transport> ecu;
  std::thread client([&] {
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(9);
    while (!ecu && std::chrono::steady_clock::now() < until) {
      ecu = open_socketcand_client("127.0.0.1", port, "can0", 1.0, error);
      if (!ecu) std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  });
  const auto start = std::chrono::steady_clock::now();
  while (!server->has_peer() && std::chrono::steady_clock::now() - start < std::chrono::seconds(9)) {
    server->wait(50'000'000);
    server->receive(none);
  }
  client.join();
  const double waited_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_TRUE(ecu) << error;
  EXPECT_TRUE(server->has_peer());
  EXPECT_GT(waited_s, 4.0);  // the silent ones had their 5 s
  EXPECT_GE(server->counters().error_frames, 8);
  // the ECU's connections while every slot was taken: refused, and said so (not "malformed")
  EXPECT_GE(server->counters().peers_refused, 1);
  EXPECT_EQ(server->counters().rx_malformed, 0);
  for (int fd : silent) ::close(fd);
}


// An ECU started before its plant listens (the plant is still loading its scenario) connects
// once the plant is up, within its timeout; with nobody listening it gives up at the timeout
// and says so.
TEST(SocketcandClient, WaitsForAPlantThatIsNotListeningYet) {
  const std::uint16_t port = free_port();
  std::string error;
  std::unique_ptr<Transport> ecu;
  std::thread client([&] { ecu = open_socketcand_client("127.0.0.1", port, "can0", 5.0, error); });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // refused until now
  std::string server_error;
  auto server = open_socketcand_server("127.0.0.1", port, server_error);
  ASSERT_TRUE(server) << server_error;
  Frame none[4];
  const auto start = std::chrono::steady_clock::now();
  while (!server->has_peer() && std::chrono::steady_clock::now() - start < std::chrono::seconds(4)) {
    server->wait(20'000'000);
    server->receive(none);
  }
  client.join();
  EXPECT_TRUE(ecu) << error;
  EXPECT_TRUE(server->has_peer());
}

TEST(SocketcandClient, GivesUpAtItsTimeoutWhenNothingListens) {
  const std::uint16_t port = free_port();
  std::string error;
  const auto start = std::chrono::steady_clock::now();
  auto ecu = open_socketcand_client("127.0.0.1", port, "can0", 0.5, error);
  const double waited_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_FALSE(ecu);
  EXPECT_NE(error.find("cannot connect: Connection refused (nothing listened there within the 0.5 s it waits)"),
            std::string::npos)
      << error;
  EXPECT_GT(waited_s, 0.4);  // it tried again until its timeout
  EXPECT_LT(waited_s, 3.0);  // and no longer
}

// Reads from fd until text holds want (or 3 s pass); what was read.
std::string read_until(int fd, const std::string& want) {
  std::string text;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  char buf[512];
  while (text.find(want) == std::string::npos && std::chrono::steady_clock::now() < until) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n > 0) text.append(buf, static_cast<std::size_t>(n));
    if (n <= 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return text;
}

// A raw-mode client on the server: connected, greeted, opened; its fd.
int raw_client(Transport& server, std::uint16_t port) {
  const int fd = connect_to(port);
  Frame none[4];
  const auto pump_until = [&](const std::string& want) {
    std::string got;
    for (int i = 0; i < 200 && got.find(want) == std::string::npos; ++i) {
      // as the plant's loops drive it: wait() sees a new connection, receive() accepts it (a
      // receive() alone accepts at most every 10 ms: not an accept4() per call)
      server.wait(0);
      server.receive(none);
      got += read_until(fd, want);
    }
    return got;
  };
  EXPECT_NE(pump_until("< hi >").find("< hi >"), std::string::npos);
  const std::string open = "< open can0 >";
  ::send(fd, open.data(), open.size(), 0);
  EXPECT_NE(pump_until("< ok >").find("< ok >"), std::string::npos);
  const std::string raw = "< rawmode >";
  ::send(fd, raw.data(), raw.size(), 0);
  EXPECT_NE(pump_until("< ok >").find("< ok >"), std::string::npos);
  return fd;
}

// Data segments that have come in on a socket (TCP_INFO).
std::uint32_t data_segments_in(int fd) {
  tcp_info info{};
  socklen_t len = sizeof info;
  if (::getsockopt(fd, IPPROTO_TCP, TCP_INFO, &info, &len) != 0) return 0;
  return info.tcpi_data_segs_in;
}

// Between cork() and uncork() a sample's frames are queued and leave in one write: one TCP
// segment for the client (the ECU wakes once per sample), the same text as frame by frame.
// Uncorked, each frame is its own segment, which shows the count tells the two apart.
TEST(SocketcandServer, ASampleSentCorkedLeavesInOneSegment) {
  const std::uint16_t port = free_port();
  std::string error;
  auto server = open_socketcand_server("127.0.0.1", port, error);
  ASSERT_TRUE(server) << error;
  const int fd = raw_client(*server, port);
  for (int i = 0; i < 100 && !server->has_peer(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(server->has_peer());  // live once its "< ok >" has settled
  const auto frame = [](std::uint32_t id) {
    Frame f;
    f.id = id;
    f.len = 2;
    f.data[0] = static_cast<std::uint8_t>(id);
    f.data[1] = 0xAB;
    return f;
  };
  for (const bool corked : {true, false}) {
    const std::uint32_t before = data_segments_in(fd);
    if (corked) server->cork();
    for (std::uint32_t id = 0x201; id <= 0x204; ++id) EXPECT_TRUE(server->send(frame(id)));
    if (corked) server->uncork();
    const std::string text = read_until(fd, "< frame 204 ");
    const std::size_t a = text.find("< frame 201 "), b = text.find("< frame 202 "), c = text.find("< frame 203 "),
                      d = text.find("< frame 204 ");
    EXPECT_TRUE(a != std::string::npos && a < b && b < c && c < d && d != std::string::npos) << text;
    EXPECT_NE(text.find(" 01AB >"), std::string::npos) << text;
    EXPECT_EQ(data_segments_in(fd) - before, corked ? 1u : 4u) << (corked ? "corked" : "uncorked");
  }
  ::close(fd);
}

// One client flooding the bus (unknown ids, as fast as it can) cannot keep another's frame
// out: it holds at most its share of the plant's ring, so the other's frame comes within a
// few shares, not after the whole flood.
TEST(SocketcandServer, AFloodingClientCannotKeepAnotherOut) {
  const std::uint16_t port = free_port();
  std::string error;
  auto server = open_socketcand_server("127.0.0.1", port, error);
  ASSERT_TRUE(server) << error;
  const int flood = raw_client(*server, port);
  const int ecu = raw_client(*server, port);
  std::atomic<bool> stop{false};
  std::atomic<long> flooded{0};
  std::thread flooder([&] {
    const std::string f = "< send 7FF 1 00 > ";
    std::string chunk;
    for (int i = 0; i < 256; ++i) chunk += f;
    while (!stop.load() && flooded.load() < 40000) {
      const ssize_t n = ::send(flood, chunk.data(), chunk.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n > 0) flooded += n / static_cast<long>(f.size());
      if (n <= 0) std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  });
  while (flooded.load() < 8000) std::this_thread::sleep_for(std::chrono::milliseconds(1));  // a flood in the pipe
  // the plant reads (without taking frames) until the flood has filled what it may of the ring
  for (int i = 0; i < 200; ++i) {
    server->receive(std::span<Frame>());
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  const std::string mine = "< send 123 1 AA > ";
  ASSERT_EQ(::send(ecu, mine.data(), mine.size(), 0), static_cast<ssize_t>(mine.size()));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  long before = 0;
  bool seen = false;
  Frame out[64];
  for (int round = 0; round < 100000 && !seen; ++round) {
    const std::size_t n = server->receive(out);
    for (std::size_t i = 0; i < n && !seen; ++i) {
      if (out[i].id == 0x123) {
        seen = true;
      } else {
        ++before;
      }
    }
    if (n == 0) server->wait(1'000'000);
  }
  stop = true;
  flooder.join();
  EXPECT_TRUE(seen);
  // each client holds at most 256 frames of the ring: the flood's are ahead by at most that
  // (and what one pump took); without the share it was every flood frame buffered (> 8000)
  EXPECT_LT(before, 1024) << before << " flood frames came first";
  ::close(flood);
  ::close(ecu);
}

// Every slot held by listeners that never send (raw mode, silent): a new client makes the one
// silent the longest give up its slot once it has been silent 5 s, and ehpt's client, refused
// until then, tries again by itself.
TEST(SocketcandServer, SilentListenersMakeRoomForAnEcu) {
  const std::uint16_t port = free_port();
  std::string error;
  auto server = open_socketcand_server("127.0.0.1", port, error);
  ASSERT_TRUE(server) << error;
  std::vector<int> listeners;
  for (int i = 0; i < 8; ++i) listeners.push_back(raw_client(*server, port));
  std::unique_ptr<Transport> ecu;
  std::thread client([&] { ecu = open_socketcand_client("127.0.0.1", port, "can0", 9.0, error); });
  const auto start = std::chrono::steady_clock::now();
  Frame none[4];
  while (!ecu && std::chrono::steady_clock::now() - start < std::chrono::seconds(9)) {
    server->wait(20'000'000);
    server->receive(none);
  }
  client.join();
  EXPECT_TRUE(ecu) << error;
  EXPECT_EQ(server->counters().peers_evicted, 1);
  EXPECT_GE(server->counters().peers_refused, 1);  // refused before the 5 s, tried again
  for (int fd : listeners) ::close(fd);
}

// "< echo >" is answered as socketcand answers it, and a channel name socketcand would refuse
// gets its error (not an "< ok >" for a bus that is not there).
TEST(SocketcandServer, EchoIsAnsweredAndABadChannelIsRefused) {
  const std::uint16_t port = free_port();
  std::string error;
  auto server = open_socketcand_server("127.0.0.1", port, error);
  ASSERT_TRUE(server) << error;
  Frame none[4];
  const auto pump_until = [&](int fd, const std::string& want) {
    std::string got;
    for (int i = 0; i < 200 && got.find(want) == std::string::npos; ++i) {
      server->receive(none);
      got += read_until(fd, want);
    }
    return got;
  };
  const int ok = raw_client(*server, port);
  const std::string echo = "< echo >";
  ASSERT_EQ(::send(ok, echo.data(), echo.size(), 0), static_cast<ssize_t>(echo.size()));
  EXPECT_NE(pump_until(ok, "< echo >").find("< echo >"), std::string::npos);
  const int bad = connect_to(port);
  ASSERT_NE(pump_until(bad, "< hi >").find("< hi >"), std::string::npos);
  const std::string open = "< open can/0 >";
  ASSERT_EQ(::send(bad, open.data(), open.size(), 0), static_cast<ssize_t>(open.size()));
  const std::string reply = pump_until(bad, "< error could not open bus >");
  EXPECT_NE(reply.find("< error could not open bus >"), std::string::npos) << reply;
  EXPECT_EQ(reply.find("< ok >"), std::string::npos) << reply;
  ::close(ok);
  ::close(bad);
}

// The session's end is an orderly close: the client reads to the end of the stream (recv 0),
// never a reset, even with frames it sent that the server never read (closing a socket with
// unread bytes would send an RST: python-can clients and loggers raise ConnectionResetError).
TEST(SocketcandServer, TheSessionEndsWithAnOrderlyCloseNotAReset) {
  const std::uint16_t port = free_port();
  std::string error;
  auto server = open_socketcand_server("127.0.0.1", port, error);
  ASSERT_TRUE(server) << error;
  const int fd = connect_to(port);
  Frame none[4];
  server->receive(none);  // accepts it: "< hi >"
  ASSERT_NE(read_until(fd, "< hi >").find("< hi >"), std::string::npos);
  const std::string open = "< open can0 >", raw = "< rawmode >";
  ASSERT_EQ(::send(fd, open.data(), open.size(), 0), static_cast<ssize_t>(open.size()));
  for (int i = 0; i < 20 && !server->has_peer(); ++i) {
    server->wait(10'000'000);
    server->receive(none);
    if (read_until(fd, "< ok >").find("< ok >") != std::string::npos) break;
  }
  ASSERT_EQ(::send(fd, raw.data(), raw.size(), 0), static_cast<ssize_t>(raw.size()));
  for (int i = 0; i < 100 && !server->has_peer(); ++i) {
    server->wait(10'000'000);
    server->receive(none);
  }
  ASSERT_TRUE(server->has_peer());
  // frames the server will never read: unread bytes in its socket at the end
  const std::string frames = "< send 123 1 AA > < send 124 2 BB CC > ";
  ASSERT_EQ(::send(fd, frames.data(), frames.size(), 0), static_cast<ssize_t>(frames.size()));
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  // the server ends in a thread (it waits for our side's end); we read to the end and close
  std::thread ending([&] { server.reset(); });
  bool eof = false;
  int reset_errno = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  char buf[512];
  while (!eof && reset_errno == 0 && std::chrono::steady_clock::now() < until) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n == 0) eof = true;
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) reset_errno = errno;
    if (n < 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ::close(fd);
  ending.join();
  EXPECT_EQ(reset_errno, 0) << std::strerror(reset_errno);  // ECONNRESET without the orderly close
  EXPECT_TRUE(eof);
}

}  // namespace
}  // namespace ehpt::io::can
