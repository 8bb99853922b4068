# Browser client support (docs/stream.md, "The browser client"): the JPEG tile atlas codec. Its own library so the
# stream module's other parts merge without touching these lines.
mirage_module(stream_web
  ${CMAKE_CURRENT_LIST_DIR}/jpeg_tiles.cpp
)
target_link_libraries(mirage_stream_web PUBLIC mirage_core PRIVATE PkgConfig::STB)
