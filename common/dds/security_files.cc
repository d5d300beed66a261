#include "common/dds/security_files.h"

#include <ctime>
#include <memory>

#include <openssl/bio.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/x509.h>

namespace coins::dds {

namespace {

template <typename T, void (*Free)(T*)>
struct Deleter {
  void operator()(T* p) const { Free(p); }
};
using X509Ptr = std::unique_ptr<X509, Deleter<X509, X509_free>>;
using BioPtr = std::unique_ptr<BIO, Deleter<BIO, BIO_free_all>>;
using Pkcs7Ptr = std::unique_ptr<PKCS7, Deleter<PKCS7, PKCS7_free>>;
using StorePtr = std::unique_ptr<X509_STORE, Deleter<X509_STORE, X509_STORE_free>>;
using KeyPtr = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY, EVP_PKEY_free>>;

X509Ptr ReadCertificate(const std::string& path) {
  BioPtr in(BIO_new_file(path.c_str(), "r"));
  return X509Ptr(in ? PEM_read_bio_X509(in.get(), nullptr, nullptr, nullptr) : nullptr);
}

// "2026-12-01 10:00:00 UTC" of an ASN1 time
std::string Text(const ASN1_TIME* t) {
  std::tm tm{};
  if (ASN1_TIME_to_tm(t, &tm) != 1) return "an unreadable date";
  char out[32];
  std::strftime(out, sizeof(out), "%Y-%m-%d %H:%M:%S UTC", &tm);
  return out;
}

Status CheckIdentity(const std::string& path, const std::string& key_path, X509* ca, const std::string& ca_path) {
  X509Ptr cert = ReadCertificate(path);
  if (!cert) return Errorf("dds.security: {} is not a PEM certificate", path);
  BioPtr key_in(BIO_new_file(key_path.c_str(), "r"));
  KeyPtr key(key_in ? PEM_read_bio_PrivateKey(key_in.get(), nullptr, nullptr, nullptr) : nullptr);
  if (!key) return Errorf("dds.security: {} is not a PEM private key", key_path);
  if (X509_check_private_key(cert.get(), key.get()) != 1)
    return Errorf("dds.security: {} is not the key of {}", key_path, path);
  KeyPtr ca_key(X509_get_pubkey(ca));
  if (!ca_key || X509_verify(cert.get(), ca_key.get()) != 1)
    return Errorf("dds.security: {} is not signed by {}", path, ca_path);
  if (X509_cmp_current_time(X509_get0_notAfter(cert.get())) <= 0)
    return Errorf("dds.security: {} expired on {}", path, Text(X509_get0_notAfter(cert.get())));
  if (X509_cmp_current_time(X509_get0_notBefore(cert.get())) >= 0)
    return Errorf("dds.security: {} is not valid before {}", path, Text(X509_get0_notBefore(cert.get())));
  return Status::Ok();
}

// the text between <tag> and </tag>, or ""
std::string Element(const std::string& xml, const std::string& tag) {
  const size_t a = xml.find("<" + tag + ">");
  const size_t b = xml.find("</" + tag + ">");
  if (a == std::string::npos || b == std::string::npos || b < a) return "";
  return xml.substr(a + tag.size() + 2, b - a - tag.size() - 2);
}

// seconds since the epoch of "YYYY-MM-DDTHH:MM:SS" (UTC), or -1
std::time_t ParseUtc(const std::string& s) {
  std::tm tm{};
  if (strptime(s.c_str(), "%Y-%m-%dT%H:%M:%S", &tm) == nullptr) return -1;
  return timegm(&tm);
}

// a document signed by the CA; *content receives what was signed
Status CheckSigned(const std::string& path, X509* ca, const std::string& ca_path, std::string* content) {
  BioPtr in(BIO_new_file(path.c_str(), "r"));
  BIO* detached = nullptr;
  Pkcs7Ptr p7(in ? SMIME_read_PKCS7(in.get(), &detached) : nullptr);
  BioPtr detached_owner(detached);
  if (!p7) return Errorf("dds.security: {} is not an S/MIME signed document", path);
  StorePtr store(X509_STORE_new());
  if (!store || X509_STORE_add_cert(store.get(), ca) != 1) return Errorf("dds.security: cannot load {}", ca_path);
  BioPtr out(BIO_new(BIO_s_mem()));
  if (PKCS7_verify(p7.get(), nullptr, store.get(), detached, out.get(), 0) != 1)
    return Errorf("dds.security: {} is not signed by {}", path, ca_path);
  char* data = nullptr;
  const long n = BIO_get_mem_data(out.get(), &data);
  content->assign(data, n > 0 ? size_t(n) : 0);
  return Status::Ok();
}

Status CheckPermissionsValidity(const std::string& path, const std::string& xml) {
  const std::time_t now = std::time(nullptr);
  const std::string before = Element(xml, "not_before"), after = Element(xml, "not_after");
  const std::time_t from = ParseUtc(before), to = ParseUtc(after);
  if (from < 0 || to < 0) return Errorf("dds.security: {} has no readable <validity> dates", path);
  if (now > to) return Errorf("dds.security: {} expired on {} UTC", path, after);
  if (now < from) return Errorf("dds.security: {} is not valid before {} UTC", path, before);
  return Status::Ok();
}

}  // namespace

Status CheckSecurityFiles(const std::string& dir, const std::string& role) {
  const std::string ca_path = dir + "/ca.pem";
  X509Ptr ca = ReadCertificate(ca_path);
  if (!ca) return Errorf("dds.security: {} is not a PEM certificate", ca_path);
  COINS_RETURN_IF_ERROR(CheckIdentity(dir + "/" + role + ".pem", dir + "/" + role + ".key", ca.get(), ca_path));
  std::string governance, permissions;
  COINS_RETURN_IF_ERROR(CheckSigned(dir + "/governance.p7s", ca.get(), ca_path, &governance));
  const std::string permissions_path = dir + "/" + role + "-permissions.p7s";
  COINS_RETURN_IF_ERROR(CheckSigned(permissions_path, ca.get(), ca_path, &permissions));
  return CheckPermissionsValidity(permissions_path, permissions);
}

}  // namespace coins::dds
