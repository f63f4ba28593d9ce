// robocal::Client and the `robocal` CLI over HTTPS against the server with --tls-cert/--tls-key, using a
// self-signed certificate made at test time by the openssl command (skipped when there is none).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "cli.h"
#include "robocal/client/client.h"
#include "test_server.h"

namespace robocal {
namespace {

namespace fs = std::filesystem;

class TlsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::system("command -v openssl >/dev/null 2>&1") != 0) {
      GTEST_SKIP() << "no openssl command to make a self-signed certificate (deploy/install-deps.sh installs it)";
    }
    dir_ = fs::temp_directory_path() / ("robocal_tls_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    // A P-256 key is made in milliseconds; the certificate names the address the tests connect to.
    const std::string command =
        "openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days 2 "
        "-subj /CN=127.0.0.1 -addext subjectAltName=IP:127.0.0.1,DNS:localhost -keyout " +
        Path("key.pem") + " -out " + Path("cert.pem") + " >/dev/null 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
    server_ =
        std::make_unique<testing::TestServer>(std::vector<std::string>{"s3cret"}, Path("cert.pem"), Path("key.pem"));
  }
  void TearDown() override {
    server_.reset();
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  ClientOptions Options() const {
    ClientOptions o;
    o.server_url = server_->url();
    o.bearer_token = "s3cret";
    o.max_retries = 0;
    return o;
  }
  int RunCli(std::vector<std::string> args, std::string* err_text = nullptr) {
    std::ostringstream out, err;
    const int code = cli::Run(args, {}, out, err);
    if (err_text) *err_text = err.str();
    return code;
  }

  fs::path dir_;
  std::unique_ptr<testing::TestServer> server_;
};

TEST_F(TlsTest, TrustedByCaFile) {
  ASSERT_EQ(server_->url().rfind("https://", 0), 0u);
  ClientOptions options = Options();
  options.ca_cert_file = Path("cert.pem");
  Client c(options);
  EXPECT_EQ(c.GetHealth().status, "ok");
  EXPECT_FALSE(c.ListRobots().empty());  // the bearer token travels inside TLS
}

TEST_F(TlsTest, UntrustedCertificateIsRefused) {
  Client c(Options());  // the system's CA store does not know the self-signed certificate
  try {
    c.GetHealth();
    FAIL() << "an unknown self-signed certificate was accepted";
  } catch (const client::ConnectionError& e) {
    EXPECT_NE(std::string(e.what()).find("not trusted"), std::string::npos) << e.what();
  }
}

TEST_F(TlsTest, VerificationOffAcceptsAnyCertificate) {
  ClientOptions options = Options();
  options.verify_tls = false;
  Client c(options);
  EXPECT_EQ(c.GetHealth().status, "ok");
}

TEST_F(TlsTest, OptionsChecks) {
  ClientOptions options = Options();
  options.ca_cert_file = Path("missing.pem");
  EXPECT_THROW(Client{options}, std::invalid_argument);
  options.server_url = "http://127.0.0.1:1";
  options.ca_cert_file = Path("cert.pem");
  std::string error;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("https"), std::string::npos) << error;
}

TEST_F(TlsTest, Cli) {
  const std::string url = server_->url();
  std::string err;
  EXPECT_EQ(RunCli({"--server", url, "--token", "s3cret", "--ca-cert", Path("cert.pem"), "robots"}), cli::kExitOk);
  EXPECT_EQ(RunCli({"--server", url, "--token", "s3cret", "robots"}, &err), cli::kExitConnection);
  EXPECT_NE(err.find("not trusted"), std::string::npos) << err;
  EXPECT_EQ(RunCli({"--server", url, "--token", "s3cret", "--insecure", "robots"}, &err), cli::kExitOk);
  EXPECT_NE(err.find("WARNING"), std::string::npos) << err;
  EXPECT_EQ(RunCli({"--server", url, "--ca-cert", Path("cert.pem"), "robots"}), cli::kExitServiceError);  // 401
}

}  // namespace
}  // namespace robocal
