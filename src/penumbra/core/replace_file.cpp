#include "penumbra/core/replace_file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <system_error>

#include "penumbra/core/error.h"

namespace penumbra {

void replace_file(const std::string& path, const std::function<void(const std::string& temporary)>& write) {
  const std::filesystem::path target(path);
  const std::filesystem::path temporary = target.parent_path() / ("." + target.filename().string() + ".partial");
  try {
    write(temporary.string());
    std::error_code ec;
    std::filesystem::rename(temporary, target, ec);
    if (ec) throw Error("cannot replace the file (" + ec.message() + ")");
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(temporary, ec);
    throw;
  }
}

void replace_file_contents(const std::string& path, std::string_view bytes) {
  replace_file(path, [&](const std::string& temporary) {
    struct Closer {
      void operator()(std::FILE* f) const { std::fclose(f); }
    };
    std::unique_ptr<std::FILE, Closer> file(std::fopen(temporary.c_str(), "wb"));
    if (!file || std::fwrite(bytes.data(), 1, bytes.size(), file.get()) != bytes.size() || std::fflush(file.get()) != 0 ||
        std::fclose(file.release()) != 0)
      throw Error(std::string("cannot write (") + std::strerror(errno) + ")");
  });
}

}  // namespace penumbra
