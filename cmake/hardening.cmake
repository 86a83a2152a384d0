# SPDX-License-Identifier: BSD-3-Clause
# EHPT_HARDENING: the hardening flags of a Debian package build (dpkg-buildflags, Debian 12):
# -fstack-protector-strong, -D_FORTIFY_SOURCE=2 (the optimised build types only: glibc
# ignores it without optimisation and warns), -Wformat -Werror=format-security, and the linker's
# -z relro -z now (the GOT read-only after start-up). Included before the first target so that
# every library, executable and the Python module get them. The default and its measured cost:
# docs/packaging.md "Hardening".
option(EHPT_HARDENING "Build with Debian's hardening flags (dpkg-buildflags)" ON)
if(EHPT_HARDENING)
  add_compile_options(-fstack-protector-strong -Wformat -Werror=format-security)
  if(CMAKE_BUILD_TYPE MATCHES "^(Release|RelWithDebInfo|MinSizeRel)$")
    # -U first: a toolchain or CPPFLAGS that sets it already would be redefined (a warning)
    add_compile_options(-U_FORTIFY_SOURCE -D_FORTIFY_SOURCE=2)
  endif()
  add_link_options(LINKER:-z,relro LINKER:-z,now)
endif()
