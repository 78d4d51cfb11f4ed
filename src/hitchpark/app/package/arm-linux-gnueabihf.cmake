# A toolchain file for 32-bit ARM Linux with hard float (Debian: apt-get install gcc-arm-linux-gnueabihf).
# For another target change the triplet, e.g. aarch64-linux-gnu; for a bare-metal Cortex-M use arm-none-eabi-gcc
# with CMAKE_SYSTEM_NAME Generic and -DHITCHPARK_NMPC_NO_CLOCK (or your own HITCHPARK_NMPC_CLOCK_NS()).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-linux-gnueabihf-gcc)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
