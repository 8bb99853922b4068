/* volk's loader code, as Debian's libvulkan-volk-dev ships it (a source file, not a library). */
#include <volk.c>
