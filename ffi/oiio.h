/* A small C API over OpenImageIO, implemented in oiio.cpp. */
#pragma once
