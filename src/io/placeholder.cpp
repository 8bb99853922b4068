// The io module's sources land beside this file.
namespace mirage::io {}
