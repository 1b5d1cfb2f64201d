#include "oiio.h"
